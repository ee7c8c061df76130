"""The psychometric participant: answers a psychophysics trial (Contract C3's `psy` record: design,
level, reference, target, signal, stimulus_index, choices) the way an observer with a threshold,
a slope, a guess rate and a lapse rate would (docs/synthetic.md, "Psychophysics").

The psychometric functions are server/psychophysics's (functions.py through observer.py), so the
synthetic participant and the procedures' own observer share one definition:

    p(x) = γ + (1 − γ − λ) · F(β · (t(x) − t(α)))

- Detection (no reference: the non-signal intervals are blank) of an amplitude parameter
  (`intensity_pct`, `magnitude_pct`): x in dB re full scale, 20·log10(level / 100); α from a
  threshold-versus-frequency U (observer.ThresholdCurve: lowest at `best_hz`, Verrillo 1963) at the
  trial's carrier, plus the participant's offset.
- Discrimination (a reference value): x = |level − reference|, a Weibull in the difference with
  α = k·|reference| (Weber's law, k per parameter) or a fixed difference for the parameters Weber's
  law does not fit (angles, temperature).
- γ is the design's: 1/n for nAFC and 2IFC; the false-alarm rate for yes–no and same–different
  (a catch trial or a "same" pair is answered "yes"/"different" with that rate alone).
- Identification: Thurstonian, perceived = t(value) + N(0, σ) on the parameter's axis (log for a
  Weber parameter, σ = k; linear otherwise, σ = the difference), the answer the nearest stimulus.

A participant's own values are drawn once from (seed, participant, "psychometric") around the
population values, so the same seed gives the same observer in any process.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping, Sequence

import numpy as np

from server.psychophysics import literature
from server.psychophysics.observer import PsychometricObserver, ThresholdCurve
from server.synthetic.rng import derive_rng

AMPLITUDE_PARAMETERS = ("intensity_pct", "magnitude_pct")  # levels in % of full scale: thresholds in dB

# Weber fractions k (discrimination threshold Δ = k·reference) and, for the parameters Weber's law
# does not describe, fixed difference thresholds (in the parameter's unit). All ours: round numbers
# of the order vibrotactile studies report, for simulation, not a fit to a data set.
WEBER = {"intensity_pct": 0.2, "magnitude_pct": 0.2, "carrier_hz": 0.25, "duration_ms": 0.15,
         "period_us": 0.25, "relative": 0.15}
DIFFERENCE = {"direction_deg": 20.0, "contact_angle_deg": 10.0, "celsius": 0.5}


class PsyAnswerError(ValueError):
    """A `psy` record the model cannot answer (a missing field, an unknown design or parameter)."""


def to_db(level) -> float:
    """An amplitude level in % of full scale as dB re full scale (0 % → −inf)."""
    with np.errstate(divide="ignore"):
        return float(20.0 * np.log10(max(float(level), 0.0) / 100.0))


@dataclass(frozen=True)
class PsychometricModel:
    """Population values of the psychometric participant (defaults ours unless cited)."""
    minimum_db: float = -30.0        # detection threshold at best_hz, dB re the device's full scale (ours)
    best_hz: float = 250.0           # the U's minimum: the Pacinian channel's best frequency (Verrillo 1963)
    curvature_db: float = 6.0        # dB per squared octave away from best_hz (observer.ThresholdCurve's)
    slope: float = 0.5               # detection β per dB (Gumbel on dB: 10 → 90 % of the way in ~6 dB; ours)
    family: str = "gumbel"           # detection family on dB (Weibull on amplitude)
    discrimination_slope: float = 3.0  # Weibull β of discrimination on the difference (ours)
    carrier_hz: float = 250.0        # the carrier assumed when a trial gives none (the device's own)
    threshold_sd_db: float = 3.0     # between participants: SD of the detection threshold's offset (ours)
    slope_sd: float = 0.2            # between participants: SD of log(slope factor) (ours)
    weber_sd: float = 0.2            # between participants: SD of log(Weber-fraction factor) (ours)
    lapse_max: float = 0.04          # a participant's lapse rate is uniform in [0, lapse_max] (ours)
    false_alarm: float = 0.05        # yes on a catch trial, "different" on a same pair (ours)
    index_sd: float = 0.6            # identification without stimulus values: SD on the index axis (ours)
    weber: Mapping[str, float] = field(default_factory=lambda: MappingProxyType(dict(WEBER)))
    difference: Mapping[str, float] = field(default_factory=lambda: MappingProxyType(dict(DIFFERENCE)))

    def __post_init__(self) -> None:
        object.__setattr__(self, "weber", MappingProxyType(dict(self.weber)))
        object.__setattr__(self, "difference", MappingProxyType(dict(self.difference)))

    def curve(self) -> ThresholdCurve:
        return ThresholdCurve(self.minimum_db, self.best_hz, self.curvature_db, self.slope, family=self.family)

    def participant(self, seed: int, participant: int | str) -> "PsychometricObserverModel":
        return PsychometricObserverModel(self, seed, participant)


# The battery's simulated observers (docs/battery.md): population values from the literature
# (server/psychophysics/literature.py, the numbers the report card draws as its bands) where it has
# them, the rest the defaults above.
# - Detection: the U over carrier frequency, lowest at 250 Hz (Verrillo 1963): ThresholdCurve's
#   parabola in log2 frequency, its curvature the least-squares fit of the literature band's
#   midline (literature_curvature_db). The minimum, −40 dB re the device's full scale, is ours
#   (a device's full scale is its own).
# - Discrimination: the middle of each literature band as a Weber fraction: the amplitude JND's
#   middle in dB (Israr, Tan & Reed 2006) as 10^(dB/20) − 1, the frequency and stiffness Weber
#   fractions' middles as they are.
LITERATURE_PARAMETERS = MappingProxyType({"intensity_pct": "amplitude_jnd_db", "carrier_hz": "frequency_weber",
                                          "relative": "stiffness_weber"})  # parameter → literature.BANDS key


def weber_of(measure: str, value: float) -> float:
    """A literature band's value as a Weber fraction k (a JND in dB is the ratio 1 + k)."""
    return 10.0 ** (value / 20.0) - 1.0 if literature.BANDS[measure].unit == "dB" else value


def literature_curvature_db(best_hz: float = literature.DETECTION_BEST_HZ) -> float:
    """ThresholdCurve's curvature (dB per squared octave) fitted to the literature detection band's
    midline: the least-squares c of midline(f) ≈ c · log2(f / best_hz)², the parabola with its
    minimum (0 dB) at best_hz."""
    x2 = np.array([math.log2(e.frequency_hz / best_hz) ** 2 for e in literature.DETECTION_BAND_DB])
    mid = np.array([e.middle_db for e in literature.DETECTION_BAND_DB])
    return float(x2 @ mid / (x2 @ x2))


LITERATURE_RANGES = MappingProxyType({p: (weber_of(m, literature.BANDS[m].low), weber_of(m, literature.BANDS[m].high))
                                      for p, m in LITERATURE_PARAMETERS.items()})
LITERATURE_WEBER = MappingProxyType({**WEBER, **{p: weber_of(m, literature.BANDS[m].middle)
                                                 for p, m in LITERATURE_PARAMETERS.items()}})
LITERATURE = PsychometricModel(minimum_db=-40.0, best_hz=literature.DETECTION_BEST_HZ,
                               curvature_db=literature_curvature_db(), weber=LITERATURE_WEBER)
PRESETS = MappingProxyType({"default": PsychometricModel(), "literature": LITERATURE})


class PsychometricObserverModel:
    """One participant's observer: the population model with this participant's own draws."""

    def __init__(self, model: PsychometricModel, seed: int, participant: int | str):
        self.model = model
        rng = derive_rng(seed, participant, "psychometric")
        draws = rng.normal(0.0, 1.0, 3)
        self.offset_db = float(draws[0] * model.threshold_sd_db)
        self.slope_factor = float(math.exp(draws[1] * model.slope_sd))
        self.weber_factor = float(math.exp(draws[2] * model.weber_sd))
        self.lapse = float(rng.uniform(0.0, model.lapse_max)) if model.lapse_max > 0 else 0.0

    # -- thresholds ----------------------------------------------------------------------------
    def detection_threshold_db(self, carrier_hz: float | None) -> float:
        """This participant's detection threshold (dB re full scale) at the carrier."""
        carrier = self.model.carrier_hz if carrier_hz is None else float(carrier_hz)
        return float(self.model.curve().threshold(carrier)) + self.offset_db

    def difference_threshold(self, parameter: str, reference: float) -> float:
        """Δ at the threshold of discrimination from `reference` (Weber: k·|reference|)."""
        m = self.model
        if parameter in m.weber:
            return m.weber[parameter] * self.weber_factor * max(abs(float(reference)), 1e-9)
        if parameter in m.difference:
            return m.difference[parameter] * self.weber_factor
        raise PsyAnswerError(f"the psychometric model has no discrimination threshold for {parameter!r} "
                             f"(known: {', '.join(sorted([*m.weber, *m.difference]))})")

    def threshold(self, parameter: str, reference: float | None, stimulus: Mapping[str, Any] | None = None) -> float:
        """The true threshold α in level units: the detection amplitude (%) with a blank reference,
        else the discriminable level reference + Δ."""
        if reference is None:
            self._detectable(parameter)
            return 100.0 * 10.0 ** (self.detection_threshold_db(_carrier(stimulus)) / 20.0)
        return float(reference) + self.difference_threshold(parameter, reference)

    # -- probabilities -------------------------------------------------------------------------
    def observer(self, psy: Mapping[str, Any], guess: float, stimulus: Mapping[str, Any] | None = None):
        """(PsychometricObserver, x): the observer of this trial's comparison and the x its
        probability takes (dB of the level for detection, |level − reference| otherwise)."""
        parameter, level, reference = psy["parameter"], float(psy["level"]), psy.get("reference")
        if reference is None:
            self._detectable(parameter)
            alpha = self.detection_threshold_db(_carrier(stimulus))
            beta = self.model.slope * self.slope_factor
            return PsychometricObserver(alpha, beta, guess, self.lapse, self.model.family), to_db(level)
        delta = abs(level - float(reference))
        alpha = self.difference_threshold(parameter, reference)
        beta = self.model.discrimination_slope * self.slope_factor
        return PsychometricObserver(alpha, beta, guess, self.lapse, "weibull"), delta

    def _detectable(self, parameter: str) -> None:
        if parameter not in AMPLITUDE_PARAMETERS:
            raise PsyAnswerError(f"the psychometric model detects only amplitudes ({', '.join(AMPLITUDE_PARAMETERS)}) "
                                 f"against a blank; {parameter!r} needs a reference")

    def probability(self, psy: Mapping[str, Any], stimulus: Mapping[str, Any] | None = None) -> float:
        """p of the "signal" answer: correct (nAFC/2IFC), "yes" (yes–no), "different"
        (same–different), for this trial as presented."""
        design = psy.get("design")
        if design in ("nafc", "2ifc"):
            observer, x = self.observer(psy, 1.0 / len(_choices(psy)), stimulus)
            return float(observer.probability(x))
        if design in ("yes-no", "same-different"):
            if not psy.get("signal"):
                return self.model.false_alarm
            observer, x = self.observer(psy, self.model.false_alarm, stimulus)
            return float(observer.probability(x))
        raise PsyAnswerError(f"psy.design: {design!r} has no single probability (identification is a confusion)")

    # -- answers -------------------------------------------------------------------------------
    def answer(self, psy: Mapping[str, Any], rng: np.random.Generator,
               stimulus: Mapping[str, Any] | None = None) -> str:
        """One of psy["choices"]: the participant's answer to this trial."""
        design = psy.get("design")
        choices = _choices(psy)
        if design in ("nafc", "2ifc"):
            target = psy.get("target")
            if not isinstance(target, int) or not 1 <= target <= len(choices):
                raise PsyAnswerError(f"psy.target: a 1-based interval of {len(choices)} expected, got {target!r}")
            if rng.random() < self.probability(psy, stimulus):
                return choices[target - 1]
            others = [c for i, c in enumerate(choices) if i != target - 1]
            return others[int(rng.integers(len(others)))]
        if design == "yes-no":
            return _named(choices, "yes" if rng.random() < self.probability(psy, stimulus) else "no")
        if design == "same-different":
            return _named(choices, "different" if rng.random() < self.probability(psy, stimulus) else "same")
        if design == "identification":
            return choices[self.identify(psy, rng)]
        raise PsyAnswerError(f"psy.design: unknown design {design!r} "
                             "(yes-no, nafc, 2ifc, same-different, identification)")

    def identify(self, psy: Mapping[str, Any], rng: np.random.Generator) -> int:
        """The index of the identified stimulus: Thurstonian noise on the parameter's axis, the
        nearest stimulus value; without values, noise on the index axis."""
        choices = _choices(psy)
        index = psy.get("stimulus_index")
        if not isinstance(index, int) or not 0 <= index < len(choices):
            raise PsyAnswerError(f"psy.stimulus_index: an index into {len(choices)} stimuli expected, got {index!r}")
        axis, sd = self._identification_axis(psy, choices)
        if self.lapse and rng.random() < self.lapse:
            return int(rng.integers(len(choices)))
        perceived = axis[index] + rng.normal(0.0, sd)
        return int(np.argmin(np.abs(axis - perceived)))

    def confusion(self, psy: Mapping[str, Any]) -> np.ndarray:
        """p[s, j]: the probability that `identify` answers j to stimulus s (each row sums to 1):
        the Gaussian noise's mass between the midpoints around stimulus j, mixed with the lapse's
        uniform guess. For an identification experiment's exact information transfer."""
        from scipy.stats import norm

        choices = _choices(psy)
        k = len(choices)
        axis, sd = self._identification_axis(psy, choices)
        order = np.argsort(axis)
        sorted_axis = axis[order]
        edges = np.concatenate(([-np.inf], (sorted_axis[1:] + sorted_axis[:-1]) / 2.0, [np.inf]))
        p = np.empty((k, k))
        for s in range(k):
            mass = np.diff(norm.cdf(edges, loc=axis[s], scale=sd))
            p[s, order] = mass
        return (1.0 - self.lapse) * p + self.lapse / k

    def _identification_axis(self, psy: Mapping[str, Any], choices: Sequence) -> tuple[np.ndarray, float]:
        """The axis `identify` puts its noise on and the noise's SD (see there)."""
        values = _stimulus_values(psy, choices)
        parameter = psy.get("parameter")
        if values is not None and parameter in self.model.weber and min(values) > 0:
            return np.log(values), self.model.weber[parameter] * self.weber_factor
        if values is not None and parameter in self.model.difference:
            return np.asarray(values, dtype=float), self.model.difference[parameter] * self.weber_factor
        return np.arange(len(choices), dtype=float), self.model.index_sd * self.weber_factor


def _choices(psy: Mapping[str, Any]) -> list:
    choices = psy.get("choices")
    if not isinstance(choices, Sequence) or isinstance(choices, str) or len(choices) < 2:
        raise PsyAnswerError(f"psy.choices: at least two choices expected, got {choices!r}")
    return list(choices)


def _named(choices: Sequence, name: str):
    for choice in choices:
        if str(choice).lower() == name:
            return choice
    raise PsyAnswerError(f"psy.choices: no {name!r} among {list(choices)!r}")


def _carrier(stimulus: Mapping[str, Any] | None) -> float | None:
    value = (stimulus or {}).get("carrier_hz")
    return None if value is None else float(value)


def _stimulus_values(psy: Mapping[str, Any], choices: Sequence) -> list[float] | None:
    """The k stimuli's values: psy["stimuli"] when the engine gives them, else numeric choices."""
    for candidate in (psy.get("stimuli"), choices):
        if isinstance(candidate, Sequence) and len(candidate) == len(choices):
            try:
                values = [float(v) for v in candidate]
            except (TypeError, ValueError):
                continue
            if all(math.isfinite(v) for v in values):
                return values
    return None
