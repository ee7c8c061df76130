"""The device battery's parts (issue 38, docs/battery.md): what each part measures, the study task
that measures it on a given device, and whether that device can show it.

One catalogue: the study-file generator (server/battery/study_file.py), the report card and the
docs read PARTS and `plan_for`. Whether a device can show a part is never decided here: a
psychophysics part asks the study loader's own device check
(server/experiment/psychophysics_task.device_refusal), the positioning part the scenarios'
capability check (devices/capability.py), and a skipped part carries their words.

Every psychophysics part is participant-paced (PACING, the task's `[tasks.pacing]` table): the
participant's answer ends a trial, the next starts ITI_MS later, no feedback, a break every N trials
with N from the part's own trial duration so that no stretch of trials is longer than STRETCH_S.
The positioning part stays experimenter-paced (its trials end at an insertion, not an answer).

Durations are computed from each task's stimulus timing (Contract C1: lead, intervals, gaps) and
its trial counts: a trial is its stimulus, ANSWER_S for the answer and the inter-trial interval;
each break within a part counts BREAK_S.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping

from devices.capability import check as capability_check
from devices.profiles import profile_by_model
from scenarios import registry
from server.core.did_you_mean import did_you_mean
from server.experiment.psychophysics_task import device_refusal

CARRIERS_HZ = (40, 80, 160, 250, 320, 400)  # detection vs carrier where the device can vary it (issue 38)
ANSWER_S = 1.0             # per trial after the last interval: the participant's answer (ours)
POSITIONING_TRIAL_S = 40.0  # one positioning trial: reach, hold 2 s at the target, insert (ours; docs/battery.md)
TIMING = MappingProxyType({"lead_ms": 400, "duration_ms": 300, "isi_ms": 400})  # short, realistic 2IFC timing

# How a psychophysics part is paced (docs/battery.md "Counterbalancing and breaks"): by the
# participant, 1 s from an answer to the next trial's start, no feedback (feedback moves a
# participant's criterion, and a battery compares devices measured the same way), and a break
# (the participant continues when ready) every `break_every(...)` trials.
PACING = MappingProxyType({"by": "participant", "iti_ms": 1000, "feedback": False})
STRETCH_S = 300.0          # the longest stretch of trials without a break: about 5 min (ours)
BREAK_S = 60.0             # a break within a part, as counted in the part's minutes (ours: an assumption)

# Main trials per participant (per interleaved condition for detection): the power analysis's
# (server/simulate/battery_trial_counts.py: the smallest count whose per-participant SE meets each part's
# target_se below; `viestac battery --trial-counts` prints it, tests/battery/test_trial_counts.py
# fails when this table is not what it derives). Positioning: the thesis's three objects.
TRIALS = MappingProxyType({
    "detection": 60, "amplitude_jnd": 50, "frequency_jnd": 50, "tilt_direction": 80,
    "temperature_change": 120, "texture_period": 50, "stiffness": 80, "angle_identification": 80,
    "positioning": 3,
})
MIN_TRIALS = 10  # fewer main trials cannot estimate anything (a staircase's first reversals)
PRACTICE = 2  # practice trials per psychophysics part (at an easy level, not analysed)


@dataclass(frozen=True)
class Part:
    id: str            # "detection", "amplitude_jnd", "frequency_jnd", "tilt_direction",
                       # "temperature_change", "texture_period", "stiffness", "angle_identification", "positioning"
    title: str
    measure: str       # "threshold" | "jnd" | "weber" | "it_bits" | "positioning"
    parameter: str     # the stimulus scenario parameter the level drives ("" for positioning)
    unit: str
    reference: float | None = None  # the reference level of a discrimination part (None: detection, IT)
    target_se: float = 0.0  # the per-participant standard error its trial count aims at (server/simulate/battery_trial_counts.py)


@dataclass(frozen=True)
class PartPlan:
    part: Part
    runs: bool
    reason: str | None  # why it is skipped: the capability check's words
    trials: int         # main trials per participant (0 when skipped)
    minutes: float      # expected duration per participant (breaks within the part included)
    task: Mapping[str, Any] | None = field(default=None, compare=False)  # the study's [[tasks]] table (None: skipped)
    conditions: tuple[str, ...] = ()  # interleaved conditions (detection: f40, f80, …)
    breaks: int = 0     # breaks within the part (participant-paced parts)


# target_se: the per-participant standard error each part's trial count aims at (server/simulate/battery_trial_counts.py):
# detection 2 dB (a group of 12 then has about 0.6 dB from the measurement, well under the 3 dB
# between participants); a discrimination part a fifth of the literature population's value
# (amplitude JND 2.3 dB, Weber fractions 0.25 and 0.185, tilt 20°, temperature 0.5 °C; docs/battery.md);
# identification 0.15 bits, a tenth of the population's IT. Ours.
PARTS: tuple[Part, ...] = (
    Part("detection", "Detection threshold against carrier frequency", "threshold", "intensity_pct", "%",
         target_se=2.0),
    Part("amplitude_jnd", "Amplitude discrimination (JND)", "jnd", "intensity_pct", "%", 40.0, target_se=0.46),
    Part("frequency_jnd", "Frequency discrimination (Weber fraction)", "weber", "carrier_hz", "Hz", 160.0,
         target_se=0.05),
    Part("tilt_direction", "Tilt-direction discrimination", "jnd", "direction_deg", "deg", 90.0, target_se=4.0),
    Part("temperature_change", "Temperature-change detection", "threshold", "celsius", "°C", 32.0, target_se=0.1),
    Part("texture_period", "Texture period discrimination (Weber fraction)", "weber", "period_us", "µs", 4000.0,
         target_se=0.05),
    Part("stiffness", "Stiffness discrimination (Weber fraction)", "weber", "relative", "", 0.5, target_se=0.037),
    Part("angle_identification", "Contact-angle identification (information transfer)", "it_bits",
         "contact_angle_deg", "deg", target_se=0.15),
    Part("positioning", "Positioning with the device's guidance (thesis task 4)", "positioning", "", ""),
)
BY_ID = MappingProxyType({p.id: p for p in PARTS})
ANGLES_DEG = (-60, -30, 0, 30, 60)


def _staircase(start: float, low: float, high: float, trials: int, scale: str, steps: list[float]) -> dict:
    """A 1-up/3-down staircase (79.4 % correct, Levitt 1971), fixed length so the duration is known,
    the estimate the mean of the last 6 reversals."""
    return {"kind": "up-down", "scale": scale, "start": start, "steps": steps, "up": 1, "down": 3,
            "min": low, "max": high, "max_trials": trials, "average": 6}


def _discrimination(part: Part, params: dict, procedure: dict, trials: int, practice_level: float) -> dict:
    return {"params": params,
            "psychophysics": {"design": "2ifc", "parameter": part.parameter, "max_trials": trials,
                              "reference": part.reference, "practice_levels": [practice_level],
                              "procedure": procedure}}


def psy_task(part: Part, model: str, can_vary_carrier: bool, trials: int | None = None) -> dict:
    """The [[tasks]] table's part-specific fields (id, scenario, device, titles added by the caller),
    with `trials` main trials (per carrier for detection; default TRIALS)."""
    timing = dict(TIMING)
    if part.id == "detection":
        carriers = CARRIERS_HZ if can_vary_carrier else (profile_by_model(model).carrier_hz,)
        per = TRIALS["detection"] if trials is None else trials
        staircase = _staircase(10, 0.2, 100, per, "db", [8, 4])
        return {"params": {"cue": "vibration", **timing},
                "psychophysics": {
                    "design": "2ifc", "parameter": part.parameter, "max_trials": per * len(carriers),
                    "practice_levels": [80],
                    "procedure": {"kind": "interleaved", "conditions": {f"f{c:g}": dict(staircase) for c in carriers}},
                    "conditions": {f"f{c:g}": {"carrier_hz": c} for c in carriers} if can_vary_carrier else {}}}
    n = TRIALS[part.id] if trials is None else trials
    ref = part.reference
    if part.id == "amplitude_jnd":
        return _discrimination(part, {"cue": "vibration", **timing},
                               _staircase(60, 40.4, 100, n, "db", [1.5, 0.5]), n, 80)
    if part.id == "frequency_jnd":
        return _discrimination(part, {"cue": "vibration", "intensity_pct": 80, **timing},
                               _staircase(240, 161, 400, n, "log", [1.12, 1.04]), n, 320)
    if part.id == "tilt_direction":
        return _discrimination(part, {"cue": "tilt", "magnitude_pct": 100, **timing, "duration_ms": 500},
                               _staircase(150, 91, 180, n, "linear", [12, 4]), n, 180)
    if part.id == "temperature_change":  # a change held long enough to be felt through the skin's lag
        return _discrimination(part, {"cue": "temperature", **timing, "duration_ms": 1500, "isi_ms": 1500},
                               _staircase(ref + 3, ref + 0.1, ref + 8, n, "linear", [0.8, 0.2]), n, ref + 5)
    if part.id == "texture_period":
        return _discrimination(part, {"cue": "texture", "duty": 0.5, "intensity_pct": 80, **timing},
                               _staircase(6000, 4040, 12000, n, "log", [1.12, 1.04]), n, 8000)
    if part.id == "stiffness":
        return _discrimination(part, {"cue": "stiffness", **timing, "duration_ms": 500},
                               _staircase(0.8, 0.505, 1.0, n, "log", [1.12, 1.04]), n, 1.0)
    if part.id == "angle_identification":  # each angle as a tilt toward (−angle), as the contact-angle task shows it
        repeats = n // len(ANGLES_DEG)
        return {"params": {"cue": "tilt", "magnitude_pct": 100, "lead_ms": 400, "duration_ms": 800},
                "psychophysics": {"design": "identification", "parameter": part.parameter,
                                  "max_trials": repeats * len(ANGLES_DEG), "labels": [f"{a:g}" for a in ANGLES_DEG],
                                  "procedure": {"kind": "constant", "levels": list(ANGLES_DEG),
                                                "repeats": repeats, "order": "random"}}}
    raise KeyError(part.id)


def _positioning_task(model: str) -> dict:
    """The thesis's positioning task (scenarios/positioning.py) with the device's own guidance: the
    FerroVibe's 3-DoF tilt guidance where the device tilts, else the vibration pattern P1; the three
    objects once each, one practice trial. Experimenter-paced: a trial ends at the object's insertion,
    not at an answer the pacer could wait for, and the experimenter watches the reach and the tracking."""
    tilts = device_refusal("direction_deg", {"cue": "tilt"}, model) is None
    cue = "3dof" if tilts else "P1"
    from scenarios.positioning import ITEM_IDS
    return {"params": {"cue": cue}, "order": "random", "practice": 1,
            "conditions": [{"object": o, "cue": cue} for o in ITEM_IDS[:TRIALS["positioning"]]]}


def _positioning_refusal(model: str) -> str | None:
    spec = registry.resolve("positioning")
    report = capability_check(spec.id, tuple(spec.factory.REQUIRES), {model: profile_by_model(model)})
    return None if report.ok else report.message


def trial_s(task: Mapping[str, Any]) -> float:
    """One paced trial's duration, start to start: the stimulus (Contract C1 timing), ANSWER_S and the
    inter-trial interval."""
    params, psy = task["params"], task["psychophysics"]
    n = 1 if psy["design"] in ("yes-no", "identification") else 2
    lead, duration, isi = (params.get(k, d) for k, d in (("lead_ms", 500), ("duration_ms", 500), ("isi_ms", 500)))
    return (lead + n * duration + (n - 1) * isi) / 1000.0 + ANSWER_S + PACING["iti_ms"] / 1000.0


def break_every(task: Mapping[str, Any]) -> int:
    """Trials between two breaks of a paced part: as many as fit in STRETCH_S (at least one)."""
    return max(1, math.floor(STRETCH_S / trial_s(task)))


def plan_part(part: Part, model: str, trials: int | None = None) -> PartPlan:
    """`part` on device `model`: its task table, trials and minutes, or skipped with the check's
    reason. `trials`: main trials instead of TRIALS (per carrier for detection)."""
    if part.id == "positioning":
        reason = _positioning_refusal(model)
        if reason:
            return PartPlan(part, False, reason, 0, 0.0)
        task = _positioning_task(model)
        trials = len(task["conditions"])
        return PartPlan(part, True, None, trials, round((trials + task["practice"]) * POSITIONING_TRIAL_S / 60.0, 1),
                        MappingProxyType(task))
    can_vary_carrier = device_refusal("carrier_hz", {"cue": "vibration"}, model) is None
    task = psy_task(part, model, can_vary_carrier, trials)
    fixed = [dict(task["params"], **c) for c in task["psychophysics"].get("conditions", {}).values()] or [task["params"]]
    for params in fixed:
        refused = device_refusal(part.parameter, params, model)
        if refused is not None:
            return PartPlan(part, False, refused[1], 0, 0.0)
    psy = task["psychophysics"]
    trials = psy["max_trials"]
    practice = len(psy.get("practice_levels", ())) and PRACTICE
    task = {**task, "practice": practice} if practice else task
    every = break_every(task)
    task = {**task, "pacing": {**PACING, "break_every": every}}
    paced = trials + practice  # the pacer runs the practice trials too, and counts them towards a break
    breaks = (paced - 1) // every  # never after the part's last trial
    conditions = tuple(psy["procedure"]["conditions"]) if psy["procedure"]["kind"] == "interleaved" else ()
    return PartPlan(part, True, None, trials, round((paced * trial_s(task) + breaks * BREAK_S) / 60.0, 1),
                    MappingProxyType(task), conditions, breaks)


def plan_for(device_model: str, trials: Mapping[str, int] | None = None) -> tuple[PartPlan, ...]:
    """Every part on `device_model` (a built-in or audio profile): runnable, or skipped with the
    capability check's reason. `trials`: {part id: main trials} instead of TRIALS for those parts.
    ProfileError for an unknown model, ValueError naming a bad override."""
    profile_by_model(device_model)
    trials = dict(trials or {})
    check_trial_overrides(trials)
    return tuple(plan_part(part, device_model, trials.get(part.id)) for part in PARTS)


def check_trial_overrides(trials: Mapping[str, Any]) -> None:
    """ValueError naming the part or the count: a psychophysics part's id, a whole number of
    trials at least MIN_TRIALS (an identification part's a multiple of its stimuli)."""
    for part_id, count in trials.items():
        if part_id not in BY_ID or part_id == "positioning":
            known = [p.id for p in PARTS if p.id != "positioning"]
            hint = " (positioning runs the thesis's three objects once each)" if part_id == "positioning" else \
                did_you_mean(str(part_id), known)
            raise ValueError(f"trials: {part_id!r} is not a psychophysics part of the battery{hint}")
        if isinstance(count, bool) or not isinstance(count, int) or count < MIN_TRIALS:
            raise ValueError(f"trials: {part_id} = {count!r}: a whole number of at least {MIN_TRIALS} expected")
        if part_id == "angle_identification" and count % len(ANGLES_DEG):
            raise ValueError(f"trials: angle_identification = {count}: a multiple of its {len(ANGLES_DEG)} "
                             f"angles expected (each shown equally often)")
