"""Observer models: how a synthetic participant turns a stimulus into an answer.

Each model is a frozen dataclass of its parameters with a `sample(rng, …)` method that is a
pure function of the parameters, the stimulus and the generator it is given (a
`numpy.random.Generator`; `rng.derive_rng` makes one per answer). Defaults come from the
thesis's reported results (chapter 5) where it reports them; the rest are ours, chosen so that
a default simulated study resembles the real one. docs/synthetic.md lists every formula,
parameter, default and source; the comments below say "thesis §…" or "ours".

Change a parameter with `dataclasses.replace(model, field=value)`, or for a whole set
`ObserverModels().with_overrides({"identification.weber": 0.2})`.

Theory of operation (log means the natural logarithm throughout):
- angle (task 1): answer = round_step(clip(c·θ + N(0, sd(θ)))), sd growing with |θ|; the
  compression toward 0 and the noise make the mean absolute deviation U-shaped over θ.
- texture comparison (task 2A): the two textures are perceived as log f + N(0, w) each; the
  difference (first − second, > 0 when the second is lower, i.e. rougher) inside ±same_band is
  "same" (the midpoint), outside it is midpoint ± max(1, round(gain·|d|)).
- identification (task 2B): Thurstonian: perceived = log f + N(0, w), the answer is the choice
  nearest in log frequency. w = 0 always answers right.
- magnitude estimation / production (task 3): p = a·S^b·exp(N(0, σ)), stochastically rounded
  (up with probability equal to the fractional part), clipped to the scale.
- Likert items: rating = round(μ(question, condition) + participant leniency + N(0, sd)),
  clipped to the scale.
- forced choices: Thurstonian utilities u_k + N(0, sd); the best one, or the "same" choice
  when the best two differ by less than a threshold.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping, Sequence

import numpy as np

from server.synthetic.psychometric import PsychometricModel


def _frozen(mapping: Mapping) -> Mapping:
    """A read-only copy, nested mappings included (the models are frozen)."""
    return MappingProxyType({k: _frozen(v) if isinstance(v, Mapping) else v for k, v in mapping.items()})


def _clip(x: float, low: float | None, high: float | None) -> float:
    if low is not None:
        x = max(low, x)
    if high is not None:
        x = min(high, x)
    return x


def stochastic_round(rng: np.random.Generator, x: float) -> int:
    """⌊x⌋ + 1 with probability x − ⌊x⌋, else ⌊x⌋: a participant torn between two whole
    numbers names the nearer one more often; the expected answer is x itself."""
    base = math.floor(x)
    return int(base + (rng.random() < x - base))


# ---- task 1: contact angle -------------------------------------------------------------------

@dataclass(frozen=True)
class AngleEstimation:
    """The named angle for a presented contact angle θ (degrees, −90..90):

    answer = step·round(clip(c·θ + N(0, sd(θ)), −90, 90) / step),
    sd(θ) = sd_center + (sd_edge − sd_center)·(|θ|/90)^shape.

    c < 1 compresses toward 0, the reference participants were given (§5.7); with the noise
    growing with |θ| the mean absolute deviation is U-shaped (§5.2.3: "deviations and variances
    in deviations increased for larger angles"). The thesis gives the shape, not the numbers
    (Figure 5.2 only): the defaults are ours, chosen so that the mean absolute deviation is
    about 8° at ±10°, 9.5° at ±30°, 11.5° at ±50° and 13° at ±70° and ±90°, and a study of 13
    simulated participants usually shows a significant quadratic trend (67 % of 200 simulated
    studies) but a non-significant Greenhouse-Geisser rm-ANOVA (85 %), as the thesis found
    (F(3.4, 38.9) = 1.57, n.s.; quadratic F(1, 126) = 4.0, p < .05).
    """
    compression: float = 0.88     # c: mean answer = c·θ (ours)
    sd_center_deg: float = 10.0   # noise SD at θ = 0 (ours)
    sd_edge_deg: float = 18.0     # noise SD at |θ| = 90 (ours)
    shape: float = 2.0            # how the SD grows from the centre to the edge (2: quadratic; ours)
    step_deg: float = 5.0         # answers are whole multiples of this, as a voiced angle (ours)

    def sd(self, angle_deg: float) -> float:
        return self.sd_center_deg + (self.sd_edge_deg - self.sd_center_deg) * (abs(angle_deg) / 90.0) ** self.shape

    def sample(self, rng: np.random.Generator, angle_deg: float, low: float = -90.0, high: float = 90.0) -> float:
        x = _clip(self.compression * angle_deg + rng.normal(0.0, 1.0) * self.sd(angle_deg), low, high)
        if self.step_deg > 0:
            x = self.step_deg * round(x / self.step_deg)
            # rounding may step past a bound that is not a multiple of the step
            while x > high:
                x -= self.step_deg
            while x < low:
                x += self.step_deg
        return float(x) + 0.0  # no −0.0


# ---- task 2A: texture comparison -------------------------------------------------------------

@dataclass(frozen=True)
class TextureComparison:
    """"Second vs first" on a Likert scale (1 much smoother, 4 same, 7 much rougher; the
    texture scenario's LIKERT, thesis §5.3.2): a lower frequency is rougher.

    d = (log f1 + N(0, w)) − (log f2 + N(0, w))  (> 0: the second felt rougher);
    |d| < same_band → the midpoint ("same"); else midpoint ± min(half, max(1, round(gain·|d|))),
    + when the second felt rougher (rougher_is_high) and − when smoother.

    Defaults (ours; the thesis reports only the figure and the tests, §5.3.3): w = 0.14, a
    Weber fraction of about 20 % at 75 % correct, typical of vibrotactile frequency
    discrimination; same_band = 0.25 makes 250 vs 250 Hz "same" about 80 % of the time (the
    thesis: "very small variance"); gain = 4 puts 166.67 vs 250 Hz near 5.5 and 500 vs 250 Hz
    near 1.5, while 200 and 333.33 Hz against 250 Hz spread around 4..5 and 3..4 (the thesis:
    not clearly distinguished, high variance).
    """
    weber: float = 0.14           # w, SD of each texture's perceived log frequency (ours)
    same_band: float = 0.25       # |perceived log difference| below this is "same" (ours)
    gain: float = 4.0             # scale points per unit of log-frequency difference (ours)
    rougher_is_high: bool = True  # the scale's high end is "much rougher" (texture LIKERT)

    def sample(self, rng: np.random.Generator, first_hz: float, second_hz: float, low: int = 1,
               high: int = 7) -> int:
        low, high = int(low), int(high)
        mid = low + (high - low) // 2
        noise = rng.normal(0.0, 1.0, 2) * self.weber
        d = (math.log(first_hz) + noise[0]) - (math.log(second_hz) + noise[1])
        if abs(d) < self.same_band:
            return mid
        steps = max(1, round(self.gain * abs(d)))
        up = (d > 0) == self.rougher_is_high
        return min(high, mid + steps) if up else max(low, mid - steps)


# ---- task 2B: frequency identification --------------------------------------------------------

@dataclass(frozen=True)
class FrequencyIdentification:
    """Which of the named frequencies a texture is (Thurstonian confusion with a Weber fraction):

    perceived = log f + N(0, w);  answer = the choice c minimising |log c − perceived|.

    w = 0 always answers right (Kendall's tau-b 1.0); tau falls as w grows. The default
    w = 0.30 is ours, calibrated to the thesis's tau = 0.67 (§5.3.3) for 13 participants × 5
    textures: simulated studies average tau-b ≈ 0.674 (SD 0.05 between studies). It gets 250
    and 333.33 Hz right about 33 % and 43 % of the time (the thesis: < 40 %), 200 Hz 27 %,
    the extremes 62 % and 75 %.
    """
    weber: float = 0.30           # w, SD of the perceived log frequency (ours, calibrated to tau 0.67)

    def sample(self, rng: np.random.Generator, frequency_hz: float, choices: Sequence[float]) -> int:
        """The index of the chosen frequency in `choices` (positive numbers)."""
        perceived = math.log(frequency_hz) + rng.normal(0.0, 1.0) * self.weber
        return int(np.argmin([abs(math.log(float(c)) - perceived) for c in choices]))


# ---- task 3: magnitude estimation and production ----------------------------------------------

@dataclass(frozen=True)
class PowerLaw:
    """Stevens's power law with multiplicative noise, answered as a whole number on the scale:

    p = a·S^b·exp(N(0, σ)), rounded stochastically (up with probability p − ⌊p⌋), clipped.

    S is the stimulus level (stiffness 1..10). Stochastic rounding keeps the mean answer at
    a·S^b·exp(σ²/2), so the exponent survives whole-number answers: nearest rounding would turn
    0.897·S^1.04 (within 0.2 of S at every level) into S itself, exponent 1.0.
    """
    a: float
    b: float
    noise: float = 0.05           # σ, SD of log p (ours: "modest"; the thesis reports only the fits)
    low: int = 1
    high: int = 10

    def mean(self, level: float) -> float:
        return self.a * level ** self.b

    def sample(self, rng: np.random.Generator, level: float, low: float | None = None,
               high: float | None = None) -> int:
        p = self.mean(level) * math.exp(rng.normal(0.0, 1.0) * self.noise)
        lo = self.low if low is None else max(self.low, math.ceil(low))
        hi = self.high if high is None else min(self.high, math.floor(high))
        return int(_clip(stochastic_round(rng, p), lo, hi))


# thesis §5.4.3: estimation p = 1.164·S^0.85, production p = 0.897·S^1.04 (fits on levels 2..9).
# The estimation exponent below 1 and the production exponent above 1 are Stevens's "response
# regression" (the thesis: "a tendency for response regression was observed"): the defaults
# encode it.
ESTIMATION = PowerLaw(1.164, 0.85)
PRODUCTION = PowerLaw(0.897, 1.04)


# ---- Likert items and forced choices -----------------------------------------------------------

# thesis §5.5.3: helpfulness per FingerTac pattern M = 5.26, 5.26, 5.36; FerroVibe per target
# 5.33, 5.0, 5.08 (mean 5.14); "*" for any other cue: the three patterns' mean. "By how much did
# the selected vibration mode feel better": M = 6.09.
LIKERT_MEANS = {
    "helpfulness": {"P1": 5.26, "P2": 5.26, "P3": 5.36, "3dof": 5.14, "*": 5.29},
    "better_by": 6.09,
}


@dataclass(frozen=True)
class LikertRatings:
    """A rating from a latent value per question and condition:

    rating = clip(round(μ + leniency + N(0, trial_sd)), low, high),  leniency ~ N(0, participant_sd)
    drawn once per participant.

    μ = means[question id] (a number), or means[question id][condition] where the condition is
    the first trial (else task) parameter named in condition_keys (the positioning cue: P1, P2,
    P3, 3dof), falling back to the "*" entry; a question not in `means` gets the scale's
    midpoint. Means are on the question's own scale.
    """
    means: Mapping[str, Any] = field(default_factory=lambda: _frozen(LIKERT_MEANS))  # thesis §5.5.3
    condition_keys: tuple[str, ...] = ("cue",)
    participant_sd: float = 0.6   # between participants (ours)
    trial_sd: float = 0.9         # within a participant (ours; with the above, SD ≈ 1.1 as §5.5.3)

    def __post_init__(self) -> None:
        object.__setattr__(self, "means", _frozen(self.means))
        object.__setattr__(self, "condition_keys", tuple(self.condition_keys))

    def mean(self, question_id: str, condition: Any, low: float, high: float) -> float:
        entry = self.means.get(question_id)
        if isinstance(entry, Mapping):
            entry = entry.get(str(condition), entry.get("*")) if condition is not None else entry.get("*")
        return (low + high) / 2 if entry is None else float(entry)

    def sample(self, rng: np.random.Generator, question_id: str, condition: Any = None, low: int = 1,
               high: int = 7, leniency: float = 0.0) -> int:
        x = self.mean(question_id, condition, low, high) + leniency + rng.normal(0.0, 1.0) * self.trial_sd
        return int(_clip(round(x), int(low), int(high)))


# thesis §5.5.3: 84.6 % preferred continuous vibration at the target: P = Φ(Δ/√2) → Δ = 1.44.
# Best pattern: 5 × P1, 6 × P2, 1 × P3, 1 × "all felt the same" of 13; the utilities and the
# threshold below give 38.6 / 46.6 / 7.7 / 7.2 % (fitted by us by Monte Carlo).
CHOICE_UTILITIES = {
    "better_mode": {"continuous vibration at target": 1.44, "no vibration at target": 0.0},
    "best_pattern": {"P1": 1.10, "P2": 1.25, "P3": 0.0},
}


@dataclass(frozen=True)
class ForcedChoice:
    """A forced choice from latent preferences (Thurstone case V):

    v_k = u_k + N(0, sd) for every choice that is not a "same" option; the answer is the best
    choice, or the "same" option (a choice whose text contains one of same_markers, e.g. "all
    felt the same") when the best two differ by less than same_threshold.

    u_k = utilities[question id][str(choice)], 0 for anything not listed (so an unknown question
    is answered uniformly at random).
    """
    utilities: Mapping[str, Any] = field(default_factory=lambda: _frozen(CHOICE_UTILITIES))  # thesis §5.5.3
    sd: float = 1.0
    same_threshold: float = 0.10  # fitted to the one "all felt the same" of 13 (thesis §5.5.3)
    same_markers: tuple[str, ...] = ("same",)

    def __post_init__(self) -> None:
        object.__setattr__(self, "utilities", _frozen(self.utilities))
        object.__setattr__(self, "same_markers", tuple(self.same_markers))

    def is_same(self, choice: Any) -> bool:
        return isinstance(choice, str) and any(m in choice.lower() for m in self.same_markers)

    def sample(self, rng: np.random.Generator, question_id: str, choices: Sequence[Any]) -> Any:
        """One of `choices`, as declared."""
        options = [c for c in choices if not self.is_same(c)]
        same = [c for c in choices if self.is_same(c)]
        if not options:
            return same[int(rng.integers(len(same)))]
        table = self.utilities.get(question_id, {})
        values = np.array([float(table.get(str(c), 0.0)) for c in options]) + rng.normal(0.0, 1.0, len(options)) * self.sd
        order = np.argsort(values)
        if same and len(options) > 1 and values[order[-1]] - values[order[-2]] < self.same_threshold:
            return same[0]
        return options[int(order[-1])]


# ---- the set ------------------------------------------------------------------------------------

@dataclass(frozen=True)
class ObserverModels:
    """The models one synthetic participant answers with (all defaults: a thesis-like participant)."""
    angle: AngleEstimation = AngleEstimation()
    comparison: TextureComparison = TextureComparison()
    identification: FrequencyIdentification = FrequencyIdentification()
    estimation: PowerLaw = ESTIMATION
    production: PowerLaw = PRODUCTION
    likert: LikertRatings = field(default_factory=LikertRatings)
    choice: ForcedChoice = field(default_factory=ForcedChoice)
    psychometric: PsychometricModel = field(default_factory=PsychometricModel)  # psychophysics trials
    text: str = "no comment"      # the answer to any free-text question (ours)

    def with_overrides(self, overrides: Mapping[str, Any]) -> "ObserverModels":
        """A copy with "model.field" = value changes, e.g. {"estimation.b": 0.9, "text": "ok"}.
        Numbers may be given as strings (a command line's KEY=VALUE). Mapping fields (Likert
        means, choice utilities) are replaced with dataclasses.replace instead."""
        changes: dict[str, dict[str, Any]] = {}
        top: dict[str, Any] = {}
        for key, value in overrides.items():
            name, _, sub = key.partition(".")
            names = {f.name for f in dataclasses.fields(self)}
            if name not in names:
                raise ValueError(f"unknown model {name!r} (known: {', '.join(sorted(names))})")
            current = getattr(self, name)
            if not sub:
                if not isinstance(current, str):
                    raise ValueError(f"{key}: give a field, e.g. {name}.{dataclasses.fields(current)[0].name}")
                top[name] = str(value)
                continue
            fields = {f.name: f for f in dataclasses.fields(current)}
            if sub not in fields:
                raise ValueError(f"{key}: {type(current).__name__} has no field {sub!r} "
                                 f"(fields: {', '.join(fields)})")
            changes.setdefault(name, {})[sub] = _coerce(key, getattr(current, sub), value)
        for name, fields in changes.items():
            top[name] = dataclasses.replace(getattr(self, name), **fields)
        return dataclasses.replace(self, **top)


def _coerce(key: str, current: Any, value: Any) -> Any:
    """`value` in the type of the field's current value (bool, int, float); mappings refused."""
    if isinstance(current, Mapping) or isinstance(current, tuple):
        raise ValueError(f"{key}: a {type(current).__name__} field; use dataclasses.replace")
    if isinstance(current, bool):
        if isinstance(value, str) and value.strip().lower() in ("true", "false", "1", "0", "yes", "no"):
            return value.strip().lower() in ("true", "1", "yes")
        if isinstance(value, bool):
            return value
        raise ValueError(f"{key} must be true or false, got {value!r}")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{key} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ValueError(f"{key} must be finite, got {value!r}")
    if isinstance(current, int):
        if not number.is_integer():
            raise ValueError(f"{key} must be a whole number, got {value!r}")
        return int(number)
    return number
