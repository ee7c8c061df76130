"""A synthetic participant: answers a planned trial's questions like a participant would.

    p = SyntheticParticipant(seed=2021, participant=3)           # thesis-like defaults
    value = p.answer(planned_trial, question)                    # passes question.check
    level = p.produce_level(target_level=7, seq=planned_trial.seq)  # stiffness production keys

Dispatch (`answer`), on the trial's scenario (version suffix ignored), its parameters and the
question's kind:
- contact-angle, `angle_deg` given, number question → AngleEstimation;
- texture with `second_period_us`, likert question → TextureComparison ("second vs first");
- texture with `period_us` only, choice question with numeric choices → FrequencyIdentification;
- stiffness, mode "estimation", number question → estimation PowerLaw; mode "production",
  number question → production PowerLaw (the thesis asks nothing there: see produce_level);
- a psychophysics trial (the stimulus scenario; Contract C3's `psy` record, which the engine's
  `start()` returns): `answer_psychophysics` → the psychometric participant (psychometric.py);
- anything else by kind: likert → LikertRatings, choice → ForcedChoice, number → the middle
  of its bounds (0 without bounds), text → a fixed short text.

Determinism: every answer draws from its own generator seeded with the SHA-256 of
(seed, participant, trial seq, question id) (rng.py), so the same seed gives the same answers
in any process and whatever the order of the calls; the participant's Likert leniency comes
from (seed, participant, "likert-leniency"). A participant holds no state but a counter used
only by produce_level without a seq.
"""

from __future__ import annotations

import math
import re
from typing import Any, Mapping

from server.experiment.plan import PlannedTrial
from server.experiment.question import Question, as_number
from server.synthetic.models import ObserverModels
from server.synthetic.psychometric import PsychometricObserverModel
from server.synthetic.rng import derive_rng

_VERSION = re.compile(r"-v\d+\Z")


def scenario_name(scenario_id: str) -> str:
    """"contact-angle-v1" → "contact-angle" (a bare name stays as it is)."""
    return _VERSION.sub("", scenario_id)


class SyntheticParticipant:
    """One simulated participant: `seed` is the simulation's seed, `participant` its identity in
    it (the participant index of the plan, or a code); `models` the observer models."""

    def __init__(self, seed: int, participant: int | str = 0, models: ObserverModels | None = None):
        self.seed = seed
        self.participant = participant
        self.models = models if models is not None else ObserverModels()
        self.leniency = float(derive_rng(seed, participant, "likert-leniency").normal(
            0.0, self.models.likert.participant_sd))
        self._productions = 0
        self._psychometric: PsychometricObserverModel | None = None

    def __repr__(self) -> str:
        return f"SyntheticParticipant(seed={self.seed!r}, participant={self.participant!r})"

    # -- the API ---------------------------------------------------------------------------
    def answer(self, trial: PlannedTrial | Mapping[str, Any], question: Question) -> Any:
        """The answer to `question` after `trial` (a PlannedTrial or its to_dict()), in the form
        Question.check returns (int for likert, the declared choice, …)."""
        seq, scenario, params, task_params = _trial_view(trial)
        rng = derive_rng(self.seed, self.participant, seq, question.id)
        m = self.models
        name = scenario_name(scenario)
        if name == "contact-angle" and question.kind == "number" and params.get("angle_deg") is not None:
            low = -90.0 if question.low is None else question.low
            high = 90.0 if question.high is None else question.high
            value = m.angle.sample(rng, float(params["angle_deg"]), low, high)
            return int(value) if question.integer else value
        if name == "texture" and params.get("period_us") is not None:
            if params.get("second_period_us") is not None and question.kind == "likert":
                return m.comparison.sample(rng, 1e6 / float(params["period_us"]),
                                           1e6 / float(params["second_period_us"]), question.low, question.high)
            if params.get("second_period_us") is None and question.kind == "choice" and _positive_numbers(
                    question.choices):
                k = m.identification.sample(rng, 1e6 / float(params["period_us"]),
                                            [float(c) for c in question.choices])
                return question.choices[k]
        if name == "stiffness" and question.kind == "number" and params.get("level") is not None:
            law = m.production if params.get("mode") == "production" else m.estimation
            return law.sample(rng, float(params["level"]), question.low, question.high)
        return self._generic(rng, question, params, task_params)

    @property
    def psychometric(self) -> PsychometricObserverModel:
        """This participant's psychometric observer (drawn once, from the seed and the participant)."""
        if self._psychometric is None:
            self._psychometric = self.models.psychometric.participant(self.seed, self.participant)
        return self._psychometric

    def answer_psychophysics(self, trial: Mapping[str, Any], psy: Mapping[str, Any], question_id: str = "response",
                             stimulus: Mapping[str, Any] | None = None):
        """The answer (one of psy["choices"]) to a psychophysics trial: `trial` is the started
        trial's dict (its `seq`; its `scenario_params` and `params` give the fixed stimulus, e.g. the
        carrier, unless `stimulus` is given), `psy` what the engine's start() returned under "psy"
        (Contract C3)."""
        seq = trial["seq"]
        if stimulus is None:
            stimulus = {**(trial.get("scenario_params") or {}), **(trial.get("params") or {})}
        return self.psychometric.answer(psy, derive_rng(self.seed, self.participant, seq, question_id), stimulus)

    def produce_level(self, target_level: int, seq: int | None = None) -> int:
        """The level (1..10) this participant sets the right sphere to when matching
        `target_level` (magnitude production, thesis §5.4: p = 0.897·S^1.04). Give the trial's
        seq: the draw is then keyed like an answer; without it, by this participant's count of
        productions so far (deterministic for the same sequence of calls)."""
        if seq is None:
            key: tuple = ("production", self._productions)
            self._productions += 1
        else:
            key = (seq, "produced_level")
        return self.models.production.sample(derive_rng(self.seed, self.participant, *key), float(target_level))

    # -- generic questions -------------------------------------------------------------------
    def _generic(self, rng, question: Question, params: Mapping, task_params: Mapping) -> Any:
        m = self.models
        if question.kind == "likert":
            condition = next((source[k] for k in m.likert.condition_keys for source in (params, task_params)
                              if source.get(k) is not None), None)
            return m.likert.sample(rng, question.id, condition, question.low, question.high, self.leniency)
        if question.kind == "choice":
            return m.choice.sample(rng, question.id, question.choices)
        if question.kind == "number":
            return _middle(question)
        return m.text


def _trial_view(trial: PlannedTrial | Mapping[str, Any]) -> tuple[int, str, Mapping, Mapping]:
    """(seq, scenario, params, scenario_params) of a PlannedTrial or a mapping with those keys."""
    if isinstance(trial, PlannedTrial):
        return trial.seq, trial.scenario, trial.params, trial.scenario_params
    if not isinstance(trial, Mapping) or "seq" not in trial or "scenario" not in trial:
        raise TypeError("trial must be a PlannedTrial or a mapping with at least 'seq' and 'scenario'")
    seq = trial["seq"]
    if isinstance(seq, bool) or not isinstance(seq, int):
        raise TypeError(f"trial seq must be an int, got {seq!r}")
    return seq, str(trial["scenario"]), trial.get("params") or {}, trial.get("scenario_params") or {}


def _positive_numbers(choices) -> bool:
    return bool(choices) and all(not isinstance(c, str) and (n := as_number(c)) is not None and n > 0
                                 for c in choices)


def _middle(question: Question) -> int | float:
    """A neutral answer to a number question nothing models: the middle of its bounds."""
    low, high = question.low, question.high
    if low is not None and high is not None:
        x = (low + high) / 2
    else:
        x = low if low is not None else (high if high is not None else 0.0)
    if question.integer:
        x = math.floor(x) if low is None or math.floor(x) >= low else math.ceil(x)
        return int(x)
    return float(x)
