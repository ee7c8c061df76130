"""A study task run by a psychophysical procedure (`[tasks.psychophysics]`, docs/studies.md
"Psychophysics tasks"): its table read and checked against the stimulus scenario and the task's
device, and each trial's presentation computed from the answers recorded so far.

Pure: no database, no clock. The engine hands in the task's answered trials (their
`metrics["psy"]`, Contract C3, in session order) and gets back what the next trial presents
(Contract C1 trial parameters) or the finished trial's C3 record. The level of a trial is a replay
of the recorded answers (server/psychophysics/procedures.py `replay`), never state kept in memory,
so a server restarted after a crash presents exactly what it would have presented.

Seeds: the procedure's from (study seed, participant index, task, "procedure"); each trial's
random choices (signal interval, catch trial, pair) from (study seed, participant index, task,
kind, n), n the trial's number among the task's answered trials of that kind.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Mapping, Sequence

from devices.profiles import AUDIO_PROFILES, PROFILES, Display
from scenarios.stimulus import CUE_CLASSES, DRIVEN
from server.core.did_you_mean import did_you_mean
from server.experiment.order import seed_from_parts
from server.psychophysics.designs import DESIGNS, MAX_INTERVALS, Design, Presentation, correct, outcome, parse_design, present
from server.psychophysics.interleave import Interleaved, InterleavedSpec
from server.psychophysics.procedures import parse_procedure, replay, start
from server.psychophysics.spec import Fields
from server.psychophysics.staircase import Staircase, StaircaseSpec

STIMULUS_SCENARIO = "stimulus"  # Contract C1: the scenario a psychophysics task presents with
QUESTION_ID = "response"        # the generated question every psychophysics trial asks
EXCLUDED_REASON = "procedure finished"
PSY_FIELDS = ("design", "parameter", "max_trials", "procedure", "conditions", "reference", "intervals",
              "catch_rate", "different_rate", "labels", "practice_levels")
CUE_CAPS = {"vibration": "continuous", "pulse_train": "pulse", "texture": "texture", "tilt": "tilt",
            "temperature": "temperature"}  # the firmware command a device needs to show the cue


@dataclass(frozen=True)
class PsyTask:
    design: Design
    parameter: str                            # the C1 parameter the levels drive
    unit: str
    max_trials: int                           # main trials the plan reserves
    procedure: Any                            # a parsed procedure spec (server/psychophysics/procedures.py)
    conditions: Mapping[str, Mapping[str, Any]]  # interleaved condition → fixed scenario params over the task's
    practice_levels: tuple[float, ...] = ()   # practice trials' levels, cycled (): the procedure's first level

    @property
    def procedure_kind(self) -> str:
        return self.procedure.kind

    def to_dict(self) -> dict:
        return {**self.design.to_dict(), "parameter": self.parameter, "unit": self.unit,
                "max_trials": self.max_trials, "procedure": self.procedure_kind,
                "conditions": {k: dict(v) for k, v in self.conditions.items()},
                "practice_levels": list(self.practice_levels)}


# ---- reading the table -----------------------------------------------------------------------

def parse_psychophysics(raw: Any, where: str, scenario_id: str, trial_specs: tuple, check_params,
                        params: Mapping[str, Any], device: str | None) -> PsyTask:
    """The task's `[tasks.psychophysics]` table. `trial_specs`: the scenario's TRIAL_PARAMS;
    `check_params(dict)`: the scenario's check of its PARAMS (a condition's fixed params);
    `params`: the task's checked scenario params. SpecError names the field."""
    f = Fields(raw, where)
    if not scenario_id.startswith(STIMULUS_SCENARIO + "-v"):
        raise f.error(None, f'a psychophysics task presents with scenario = "{STIMULUS_SCENARIO}", not {scenario_id}')
    parameter = f.choice("parameter", _parameters(trial_specs, f))
    max_trials = int(f.number("max_trials", low=1, whole=True))
    table = f.table_of("procedure")
    if f.choice("design", DESIGNS) == "identification":  # its answers are the procedure's levels
        spec = parse_procedure(table, f"{where}: procedure")
        design = parse_design(f, _stimuli(spec, f))
    else:  # the design's guess rate is the procedure's unless it gives one
        design = parse_design(f)
        spec = parse_procedure(_with_guess(table, design.guess), f"{where}: procedure")
    conditions = _conditions(f, spec, parameter, check_params, params)
    practice = f.numbers("practice_levels", ())
    f.done()
    psy = PsyTask(design, parameter, DRIVEN[parameter][2] if parameter in DRIVEN else "", max_trials, spec, conditions, practice)
    for name, fixed in (conditions or {"": params}).items():
        _check_levels(f, psy, {**params, **fixed}, device, name)
    return psy


def _parameters(trial_specs: tuple, f: Fields) -> tuple:
    by_name = {p.name: p for p in trial_specs}
    wanted = ("parameter", "n_intervals", *(f"level_{k}" for k in range(1, MAX_INTERVALS + 1)))
    if any(name not in by_name for name in wanted):
        raise f.error(None, f"the stimulus scenario lacks the trial parameters {', '.join(wanted)} (Contract C1)")
    return tuple(by_name["parameter"].choices)


def _with_guess(table: Mapping, guess: float) -> Mapping:
    """The procedure table with the design's guess rate where it gives none (a staircase checks
    its target against it; QUEST+ fixes it), in every interleaved condition too."""
    if not isinstance(table, Mapping):
        return table
    kind = table.get("kind")
    if kind == "interleaved" and isinstance(table.get("conditions"), Mapping):
        return {**table, "conditions": {k: _with_guess(v, guess) for k, v in table["conditions"].items()}}
    if kind in ("up-down", "weighted-up-down", "quest-plus") and "guess" not in table:
        return {**table, "guess": guess}
    return table


def _stimuli(spec, f: Fields) -> tuple[float, ...]:
    if spec.kind != "constant":
        raise f.error("procedure", f'identification presents k fixed stimuli: kind = "constant" with their levels, '
                                   f"not {spec.kind!r}")
    return tuple(spec.levels)


def _conditions(f: Fields, spec, parameter: str, check_params, params: Mapping) -> Mapping:
    raw = f.table_of("conditions", None)
    names = [name for name, _ in spec.conditions] if isinstance(spec, InterleavedSpec) else []
    if raw is None:
        return MappingProxyType({name: MappingProxyType({}) for name in names})
    if not names:
        raise f.error("conditions", 'fixed params per condition need an interleaved procedure (kind = "interleaved")')
    out = {}
    for name, fixed in raw.items():
        if name not in names:
            raise f.error("conditions", f"the procedure has no condition {name!r}{did_you_mean(str(name), names)}")
        if not isinstance(fixed, Mapping):
            raise f.error(f"conditions.{name}", f"expected a table of scenario params, got {fixed!r}")
        if parameter in fixed:
            raise f.error(f"conditions.{name}", f"{parameter} is the level the procedure drives; it cannot be fixed")
        try:
            checked = check_params({**params, **fixed})
        except ValueError as exc:
            raise f.error(f"conditions.{name}", str(exc)) from None
        out[name] = MappingProxyType({k: checked[k] for k in fixed})
    return MappingProxyType({name: out.get(name, MappingProxyType({})) for name in names})


# ---- levels within the cue's and the device's range ------------------------------------------

def parameter_range(parameter: str, cue: str) -> tuple[float, float] | None:
    """The values `parameter` may take with this cue (None: the cue has no such field): the
    stimulus scenario's own table, so the study refuses at load what the scenario would refuse."""
    cues, span, _ = DRIVEN.get(parameter, ((), None, ""))
    return span if cue in cues else None


def _check_levels(f: Fields, psy: PsyTask, params: Mapping, device: str | None, condition: str) -> None:
    cue = params.get("cue", "vibration")
    where = f'condition "{condition}": ' if condition else ""
    span = parameter_range(psy.parameter, cue)
    if span is None:
        able = sorted(c for c in CUE_CLASSES if parameter_range(psy.parameter, c) is not None)
        raise f.error("parameter", f"{where}a {cue} cue has no {psy.parameter} (cues that have it: {', '.join(able)})")
    if device is not None:
        _check_device(f, psy, params, device, where)
    low, high = span
    spec = dict(psy.procedure.conditions)[condition] if condition else psy.procedure
    for field, value in [*_level_extremes(spec), ("reference", psy.design.reference),
                         *(("practice_levels", v) for v in psy.practice_levels)]:
        if value is None:
            continue
        if not low <= value <= high:
            got = (f"missing: the procedure could step past {high if value > 0 else low:g}" if math.isinf(value)
                   else f"got {value:g}")
            raise f.error(("procedure: " + where if field not in ("reference", "practice_levels") else where) + field,
                          f"{psy.parameter} levels must stay within [{low:g}, {high:g}]{' ' + psy.unit if psy.unit else ''}"
                          f" (the {cue} cue's range); {got}")


def _level_extremes(spec) -> list[tuple[str, float]]:
    """(field, level) pairs that bound every level the procedure can present."""
    if isinstance(spec, StaircaseSpec):
        if spec.scale.kind == "ladder":
            return [("levels", min(spec.scale.ladder)), ("levels", max(spec.scale.ladder))]
        to = spec.scale.to_level
        return [("start", spec.start), ("min", to(spec.low) if math.isfinite(spec.low) else -math.inf),
                ("max", to(spec.high) if math.isfinite(spec.high) else math.inf)]
    return [("levels", min(spec.levels)), ("levels", max(spec.levels))]


def _check_device(f: Fields, psy: PsyTask, params: Mapping, device: str, where: str) -> None:
    refused = device_refusal(psy.parameter, params, device)
    if refused is not None:
        field, reason = refused
        raise f.error(field, where + reason)


def device_refusal(parameter: str, params: Mapping, device: str) -> tuple[str, str] | None:
    """(the field at fault, why) when device `device` cannot present `parameter` with these
    scenario params, else None (an unknown model too: that is the task's `device` field's error).
    The one answer to "can this device show this psychophysics task" (the battery asks it too)."""
    profile = PROFILES.get(device) or AUDIO_PROFILES.get(device)
    if profile is None:
        return None
    cue = params.get("cue", "vibration")
    fixed_carrier = profile.protocol != "audio"  # an LRA's resonance; a voice coil on a sound interface has a range
    if parameter == "carrier_hz" and fixed_carrier:
        return "parameter", (f"device {device} has a fixed carrier ({profile.carrier_hz} Hz), no carrier "
                             "range for carrier_hz levels (a broadband tactor on a sound interface has one)")
    carrier = params.get("carrier_hz")
    if fixed_carrier and carrier is not None and carrier != profile.carrier_hz:
        return "carrier_hz", f"device {device} has a fixed carrier ({profile.carrier_hz} Hz); it cannot play {carrier:g} Hz"
    cap = CUE_CAPS.get(cue)
    shown = profile.dimensions.get("stiffness") != Display.NONE if cue == "stiffness" else cap in profile.caps
    if not shown:
        return "parameter", f"device {device} cannot show a {cue} cue (it accepts {', '.join(sorted(profile.caps))})"
    return None


# ---- trials ----------------------------------------------------------------------------------

@dataclass(frozen=True)
class Seeds:
    study: int
    participant: int
    task: str

    def procedure(self) -> int:
        return seed_from_parts((self.study, self.participant, self.task, "procedure"))

    def trial(self, kind: str, n: int) -> int:
        return seed_from_parts((self.study, self.participant, self.task, kind, n))


def _presentation(psy_record: Mapping) -> Presentation:
    return Presentation((), psy_record.get("target"), psy_record.get("signal"), psy_record.get("stimulus_index"))


def track(psy: PsyTask, seeds: Seeds, answered: Sequence[Mapping]):
    """The procedure after the task's answered main trials (their C3 records, in order)."""
    outcomes = [o for o in (outcome(psy.design, _presentation(r), r["answer"]) for r in answered) if o is not None]
    return replay(psy.procedure, outcomes, seeds.procedure())


def _current(procedure) -> tuple[str | None, Any]:
    """(interleaved condition or None, the procedure that takes the next answer)."""
    if isinstance(procedure, Interleaved):
        return procedure.condition, procedure.procedures.get(procedure.condition)
    return None, procedure


def next_trial(psy: PsyTask, seeds: Seeds, answered: Sequence[Mapping], kind: str, index: int,
               params: Mapping[str, Any], procedure=None) -> dict | None:
    """What trial `index` of `kind` ("main" or "trial": practice) presents: {"psy": C3 without the
    answer's keys, "params": C1 TRIAL_PARAMS, "scenario_params": the task's with its condition's},
    or None when the procedure has finished (main trials). `procedure`: `track(...)` of the same
    answers, when the caller has it already (it is not changed)."""
    if kind == "main":
        procedure = track(psy, seeds, answered) if procedure is None else procedure
        if procedure.finished:
            return None
        condition, current = _current(procedure)
        level, n, seed = procedure.level, current.trial, seeds.trial("main", len(answered))
    else:  # practice: fixed easy levels, or the procedure's first; its answers never reach the procedure
        first = start(psy.procedure, seeds.procedure())
        condition, _ = _current(first)
        level = psy.practice_levels[index % len(psy.practice_levels)] if psy.practice_levels else first.level
        n, seed = index, seeds.trial("trial", index)
    pres = present(psy.design, float(level), seed)
    levels = list(pres.levels) + [None] * (MAX_INTERVALS - len(pres.levels))
    record = {"design": psy.design.name, "condition": condition, "parameter": psy.parameter, "unit": psy.unit,
              "level": float(level), "reference": psy.design.reference, "target": pres.target, "signal": pres.signal,
              "stimulus_index": pres.stimulus_index, "choices": list(psy.design.choices), "guess": psy.design.guess,
              "trial": int(n)}
    trial_params = {"parameter": psy.parameter, "n_intervals": psy.design.intervals,
                    **{f"level_{k + 1}": levels[k] for k in range(MAX_INTERVALS)}}
    fixed = psy.conditions.get(condition, {}) if condition else {}
    return {"psy": record, "params": trial_params, "scenario_params": {**params, **fixed}}


def conclude(psy: PsyTask, seeds: Seeds, answered: Sequence[Mapping], record: Mapping, answer: str,
             kind: str, procedure=None) -> tuple[dict, bool]:
    """The finished trial's C3 record (`record`: next_trial's psy, `answer`: the participant's) and
    whether the procedure has finished with it (main trials only). `procedure`: `track(...)` of
    `answered`, when the caller has it; it is moved on by this answer."""
    pres = _presentation(record)
    out = {**record, "answer": answer, "answer_index": psy.design.choices.index(answer),
           "correct": correct(psy.design, pres, answer), "reversal": False, "procedure": None, "estimate": None}
    if kind != "main":
        return out, False
    after = track(psy, seeds, answered) if procedure is None else procedure
    condition, reversals = _current(after)[0], _reversals(after)
    heard = outcome(psy.design, pres, answer)
    if heard is not None:  # what the replay of the answers with this one gives
        after.update(heard)
    out["reversal"] = _reversals(after, condition) > reversals
    out["procedure"], out["estimate"] = _plain(after.record()), _plain(after.estimate())
    return out, bool(after.finished)


def _reversals(procedure, condition: str | None = None) -> int:
    if isinstance(procedure, Interleaved):
        name = condition if condition is not None else procedure.condition
        procedure = procedure.procedures.get(name)
    return len(procedure.reversals) if isinstance(procedure, Staircase) else 0


def _plain(value):
    """JSON-able plain data (numpy scalars to floats)."""
    return json.loads(json.dumps(value, default=float))
