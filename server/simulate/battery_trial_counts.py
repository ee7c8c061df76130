"""The battery's trial counts from a power analysis (issue 38, docs/battery.md "Trial counts"): per
part, the smallest number of main trials whose per-participant standard error of the part's
measure meets the part's target (`Part.target_se`), for the literature's synthetic observers.

A trial's level is a pure function of the answers so far (server/psychophysics/procedures.py), so
the first T trials of a part are a part of T trials and the procedure runs without the engine
(the same code the engine runs): OBSERVERS synthetic participants of the literature population
(server/synthetic/psychometric.py LITERATURE, each with its own threshold, slope, Weber factor and
lapse) each run the part's procedure once for the grid's largest count, answering with their own
psychometric function; the estimate after T trials against the participant's own truth (the level
its function answers correctly at the staircase's target, 79.4 % for 1-up/3-down, Levitt 1971)
is the error at T: over the observers its SD is the per-participant SE, its mean the bias.
Identification: each participant's Miller–Madow information transfer from T trials against their
exact IT (their confusion probabilities).

`viestac battery --trial-counts` prints the analysis; parts.TRIALS holds its result and
tests/battery/test_trial_counts.py fails when the two differ. Pure: a seed in, a table out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from types import SimpleNamespace
from typing import Any, Callable, Iterable, Mapping

import numpy as np

from server.battery.parts import ANGLES_DEG, PARTS, Part, psy_task
from server.core.did_you_mean import did_you_mean
from server.psychophysics import information
from server.psychophysics import simulate
from server.psychophysics.procedures import parse_procedure
from server.synthetic.psychometric import LITERATURE
from server.synthetic.rng import derive_rng

GRID = (20, 30, 40, 50, 60, 80, 100, 120, 160)  # main trials per part (per carrier for detection)
OBSERVERS = 500
SEED = 38
LRA_MODEL = "fingertac"  # the built-in devices' fixed carrier (235 Hz): detection is also checked there


@dataclass(frozen=True)
class Precision:
    """One part (and condition) at one trial count: the estimate's error over the observers."""
    part: str
    condition: str
    trials: int
    bias: float   # mean(estimate − truth), in the part's measure unit
    se: float     # SD of (estimate − truth): the per-participant standard error
    unit: str


@dataclass(frozen=True)
class Count:
    part: str
    trials: int           # the smallest grid count meeting the target (the grid's largest if none does)
    target_se: float
    unit: str
    met: bool
    worst: str            # the condition that needs the most trials (detection: a carrier)


def measure_of(part: Part, level: float) -> float:
    """A level as the part's measure (the report card's): detection dB re full scale, amplitude
    JND dB re the reference, a Weber fraction, else the difference from the reference."""
    if part.reference is None:
        return 20.0 * math.log10(level / 100.0)
    if part.id == "amplitude_jnd":
        return 20.0 * math.log10(level / part.reference)
    if part.measure == "weber":
        return level / part.reference - 1.0
    return level - part.reference


def _conditions(part: Part, trials: int) -> list[tuple[str, dict, dict]]:
    """[(condition, procedure table, stimulus)] of the part with `trials` main trials: detection
    per carrier (the audio tactor's range and the LRAs' fixed carrier), else the one procedure."""
    if part.id == "detection":
        varied = psy_task(part, "audio", True, trials)["psychophysics"]["procedure"]["conditions"]
        fixed = psy_task(part, LRA_MODEL, False, trials)["psychophysics"]["procedure"]["conditions"]
        return [(name, table, {"carrier_hz": float(name[1:])}) for name, table in {**varied, **fixed}.items()]
    table = psy_task(part, LRA_MODEL, False, trials)
    return [("main", table["psychophysics"]["procedure"], dict(table["params"]))]


def target_p(spec) -> float:
    """The proportion correct a staircase converges on: p^down = 0.5 for 1-up/n-down (Levitt 1971)."""
    if getattr(spec, "up", None) != 1 or spec.kind != "up-down":
        raise ValueError("only 1-up/n-down staircases have a known convergence point")
    return 0.5 ** (1.0 / spec.down)


def truth(part: Part, person, stimulus: Mapping[str, Any], p: float) -> float:
    """The participant's own true level at proportion correct `p` of a 2IFC trial: the detection
    amplitude (%) or the comparison level a staircase converging on `p` should find."""
    record = {"parameter": part.parameter, "level": 1.0, "reference": part.reference}
    function, _ = person.observer(record, 0.5, stimulus)
    x = function.level_at(p)
    return 100.0 * 10 ** (x / 20.0) if part.reference is None else part.reference + x


def staircase_errors(part: Part, procedure_table: Mapping[str, Any], stimulus: Mapping[str, Any],
                     grid: tuple[int, ...], person_of: Callable[[int], Any], observers: int, seed: int,
                     condition: str, runs: int = 1) -> np.ndarray:
    """errors[observer · runs, i]: the part's staircase run by each observer (`person_of(index)`,
    a psychometric observer model) `runs` times, answering 2IFC trials; its estimate after grid[i]
    trials − the observer's truth, in the part's measure (measure_of)."""
    spec = parse_procedure(dict(procedure_table))
    p = target_p(spec)
    errors = np.full((observers * runs, len(grid)), np.nan)
    at = {count: i for i, count in enumerate(grid)}
    record = {"design": "2ifc", "parameter": part.parameter, "reference": part.reference, "choices": ["1", "2"]}
    for index in range(observers):
        person = person_of(index)
        true = measure_of(part, truth(part, person, stimulus, p))
        answering = SimpleNamespace(probability=lambda level, person=person: person.probability(
            {**record, "level": level}, stimulus))
        rng = derive_rng("battery-trial-counts", seed, part.id, condition, index)
        for run in range(runs):
            row = index * runs + run

            def after(procedure, trials, row=row, true=true):
                estimate = procedure.estimate() if trials in at else None
                if estimate is not None and math.isfinite(estimate):
                    errors[row, at[trials]] = measure_of(part, estimate) - true

            procedure, track = simulate.run(spec, answering, rng, seed=int(rng.integers(2 ** 31)),
                                            max_trials=grid[-1], after=after)
            for count in grid:  # a procedure that stopped early (its own max_trials): its final estimate
                if count > len(track):
                    after(procedure, count)
    return errors


def _identification_errors(part: Part, grid: tuple[int, ...], observers: int, seed: int) -> np.ndarray:
    """errors[observer, i]: the participant's Miller–Madow IT from grid[i] trials (as many of each
    stimulus) − their exact IT, in bits."""
    k = len(ANGLES_DEG)
    psy = {"parameter": part.parameter, "choices": [f"{a:g}" for a in ANGLES_DEG], "stimuli": list(ANGLES_DEG)}
    errors = np.full((observers, len(grid)), np.nan)
    for index in range(observers):
        person = LITERATURE.participant(seed, index)
        rng = derive_rng("battery-trial-counts", seed, part.id, index)
        confusion = person.confusion(psy)
        exact = information.from_distribution(confusion)
        for i, count in enumerate(grid):
            counts = np.stack([rng.multinomial(count // k, confusion[s]) for s in range(k)])
            errors[index, i] = information.information_transfer(counts).corrected - exact
    return errors


def precision(part: Part, grid: Iterable[int] = GRID, observers: int = OBSERVERS, seed: int = SEED) -> list[Precision]:
    """The part's estimate error at every count of the grid (per condition)."""
    grid = tuple(sorted(set(int(t) for t in grid)))
    unit = _unit(part)
    if part.measure == "it_bits":
        rows = [("main", _identification_errors(part, grid, observers, seed))]
    else:
        def person_of(index):
            return LITERATURE.participant(seed, index)

        rows = [(name, staircase_errors(part, table, stimulus, grid, person_of, observers, seed, name))
                for name, table, stimulus in _conditions(part, grid[-1])]
    out = []
    for condition, errors in rows:
        for i, count in enumerate(grid):
            e = errors[:, i][np.isfinite(errors[:, i])]
            out.append(Precision(part.id, condition, count, float(e.mean()), float(e.std(ddof=1)), unit))
    return out


def count_for(part: Part, rows: list[Precision]) -> Count:
    """The smallest count at which every condition's SE meets the part's target."""
    by_condition: dict[str, list[Precision]] = {}
    for row in rows:
        by_condition.setdefault(row.condition, []).append(row)
    needed, worst, met = 0, "", True
    for condition, cond_rows in sorted(by_condition.items()):
        meeting = [r.trials for r in sorted(cond_rows, key=lambda r: r.trials) if r.se <= part.target_se]
        trials = meeting[0] if meeting else max(r.trials for r in cond_rows)
        met = met and bool(meeting)
        if trials > needed:
            needed, worst = trials, condition
    return Count(part.id, needed, part.target_se, _unit(part), met, worst)


def derive(grid: Iterable[int] = GRID, observers: int = OBSERVERS, seed: int = SEED,
           parts: Iterable[Part] = PARTS, targets: Mapping[str, float] | None = None
           ) -> tuple[dict[str, Count], list[Precision]]:
    """{part id: Count} for every psychophysics part of `parts` (`targets`: {part id: SE} instead
    of a part's own target_se), and the rows behind them. ValueError naming a bad target."""
    targets = dict(targets or {})
    psychophysical = {p.id: p for p in parts if p.id != "positioning"}
    for part_id, value in targets.items():
        if part_id not in psychophysical:
            raise ValueError(f"target: {part_id!r} is not a psychophysics part of the battery"
                             f"{did_you_mean(str(part_id), psychophysical)}")
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ValueError(f"target: {part_id} = {value!r}: a standard error above 0 expected")
    if observers < 10:
        raise ValueError(f"observers: at least 10 expected, got {observers}")
    counts, rows = {}, []
    for part in psychophysical.values():
        if part.id in targets:
            part = replace(part, target_se=float(targets[part.id]))
        part_rows = precision(part, grid, observers, seed)
        rows += part_rows
        counts[part.id] = count_for(part, part_rows)
    return counts, rows


def counts_for_targets(targets: Mapping[str, float], observers: int = OBSERVERS, seed: int = SEED) -> dict[str, int]:
    """{part id: trials} meeting these per-participant SE targets (for `viestac battery --target-se`)."""
    chosen = [p for p in PARTS if p.id in targets]
    counts, _ = derive(observers=observers, seed=seed, parts=chosen or PARTS, targets=targets)
    return {k: c.trials for k, c in counts.items() if k in targets}


def _unit(part: Part) -> str:
    if part.id in ("detection", "amplitude_jnd"):  # measure_of's dB
        return "dB"
    return {"weber": "", "it_bits": "bits"}.get(part.measure, part.unit)


def report(counts: dict[str, Count], rows: list[Precision], observers: int = OBSERVERS, seed: int = SEED) -> str:
    """The analysis as text: per part the target, the SE (and bias) at every count, the chosen count."""
    lines = [f"Per-participant SE of each part's measure against its main trials ({observers} literature "
             f"observers, seed {seed}); each part's count is the smallest meeting its target."]
    for part_id, count in counts.items():
        unit = f" {count.unit}" if count.unit else ""
        lines.append(f"{part_id}: target SE {count.target_se:g}{unit} -> {count.trials} trials"
                     + ("" if count.met else " (target not met on the grid)")
                     + (f", set by {count.worst}" if count.worst not in ("", "main") else ""))
        for condition in dict.fromkeys(r.condition for r in rows if r.part == part_id):
            mine = [r for r in rows if r.part == part_id and r.condition == condition]
            lines.append(f"  {condition:>6}  trials " + "".join(f"{r.trials:>9}" for r in mine))
            lines.append(f"  {'':>6}  SE     " + "".join(f"{r.se:>9.3g}" for r in mine))
            lines.append(f"  {'':>6}  bias   " + "".join(f"{r.bias:>9.2g}" for r in mine))
    return "\n".join(lines)
