"""The battery simulated (issue 38 point 3, docs/battery.md "The simulated battery"): 12 synthetic
participants with the literature's psychometric parameters (server/synthetic/psychometric.py
LITERATURE) run each built-in device's battery study file through the real engine
(`viestac study --simulate`'s simulate_study: the virtual rig, the engine picks every level), and
every recovered threshold, JND, Weber fraction and information transfer lies within its simulated
truth's 95 % interval.

- Thresholds, JNDs, Weber fractions (staircases): per part and condition, the recovered values
  (each participant's procedure estimate after the last trial) against the participants' own true
  values (the level where their own psychometric function gives 79.4 % correct, the point a
  1-up/3-down staircase converges on, Levitt 1971): the 95 % interval (simultaneous over the
  module's 24 parts and conditions, Bonferroni) of the group's mean recovery error
  (t on 11 degrees of freedom) contains 0, and the group's mean recovered value lies within the
  truth's 95 % interval (mean true value ± that interval's half width). And the spread of the
  engine's recovery errors is the spread the power analysis behind the trial counts predicts (the
  same procedure run without the engine by the same observers: a resampling test), so
  the counts' standard errors hold for the engine.
- Information transfer (identification): the pooled confusion matrix's Miller–Madow IT lies
  within the 95 % interval of the same estimate from the same observers over REPLICATIONS repeated
  experiments of the same size (the truth's sampling interval); the exact IT of those observers
  (information.from_distribution) is reported with it.

One module-scoped simulation per device, seeded, two worker processes. What runs in the default
suite is reduced (REDUCED_FACTOR of every staircase's trials, no positioning part: its agent is
tested in tests/simulate and has no threshold to recover); VIESTAC_FULL_BATTERY=1 runs the battery
files as they are (test_the_full_battery_recovers_its_truths: many minutes, kept out of the suite). Wall times: docs/performance.md "Battery".
"""

from __future__ import annotations

import json
import math
import os
import re
import sqlite3
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import t as student_t

from devices.profiles import profile_by_model
from server.simulate import battery_trial_counts as trial_counts
from server.battery.parts import PARTS, plan_for
from server.battery.study_file import BUILT_IN, battery_study
from server.psychophysics import information
from server.simulate.effects import population
from server.simulate.study_run import simulate_study
from server.simulate.threshold_power import tracks
from server.synthetic.rng import derive_rng

PARTICIPANTS = 12
SEED = 38
WORKERS = 2
REDUCED_FACTOR = 0.5
REPLICATIONS = 400
BIAS_RUNS = 30  # procedure-only runs per participant for the procedure's own bias and spread
COMPARISONS = 24  # parts and conditions over the four devices (4 + 5 + 5 + 10) (Bonferroni for the spread test)
TARGET_P = 0.5 ** (1 / 3)  # a 1-up/3-down staircase's convergence point (Levitt 1971)
WALL_S: dict[str, float] = {}


def reduced(text: str, factor: float = REDUCED_FACTOR) -> str:
    """The battery file with every discrimination and identification part's trials scaled by
    `factor` (staircases, the tasks' reserved trials, identification repeats), detection as it is
    (its staircases descend from their start first: shorter ones would not converge), and the
    positioning task left out of the file and its block."""
    body, blocks = text.split("\n[[blocks]]\n")
    head, *tasks = body.split("\n[[tasks]]\n")
    kept = []
    for task in tasks:
        if task.startswith('id = "positioning"'):
            continue
        if not task.startswith('id = "detection"'):
            task = re.sub(r"^(max_trials|repeats) = (\d+)$",
                          lambda m: f"{m[1]} = {max(2, round(int(m[2]) * factor))}", task, flags=re.M)
        kept.append(task)
    return "\n[[tasks]]\n".join([head, *kept]) + "\n[[blocks]]\n" + blocks.replace(', "positioning"]', "]")


def simulate(model: str, text: str, root: Path):
    path = root / "studies" / f"battery-{model}.toml"
    path.parent.mkdir(parents=True)
    path.write_text(text, encoding="utf-8")
    people = population({"psychometric": "literature"})
    started = time.perf_counter()
    result = simulate_study(path, participants=PARTICIPANTS, seed=SEED, out_dir=root / "run",
                            make_participant=people.participant, workers=WORKERS)
    WALL_S[model] = time.perf_counter() - started
    assert not result.aborted, result.aborted
    observers = tracks(result.data_dir / "viestac.sqlite", lambda index: people.participant(SEED, index))
    return result, observers, people


@pytest.fixture(scope="module", params=BUILT_IN)
def battery(request, tmp_path_factory):
    model = request.param
    text = reduced(battery_study(model))
    result, observers, people = simulate(model, text, tmp_path_factory.mktemp(model))
    return model, text, result, observers, people


def target_truth(observers_of, o: dict, part, model: str) -> float:
    """The participant's own true value at the performance its staircase converges on: a 1-up/3-down
    track settles where p = 0.5 ** (1/3) = 79.4 % correct (Levitt 1971), on its own psychometric
    function (threshold, slope, guess and lapse: server/synthetic/psychometric.py). For detection the
    amplitude (%) at the condition's carrier; for discrimination the comparison level."""
    carrier = float(o["condition"][1:]) if o["condition"].startswith("f") else profile_by_model(model).carrier_hz
    return trial_counts.truth(part, observers_of(o["participant"]), {"carrier_hz": carrier}, TARGET_P)


def recovered(observers, observers_of, model: str) -> dict[tuple[str, str], dict]:
    """Per (task, condition): each participant's recovered value (its procedure's estimate after
    the last trial) and true value (target_truth), on the part's measure scale (trial_counts.measure_of: dB for detection and the amplitude JND)."""
    by_id = {p.id: p for p in PARTS}
    groups: dict[tuple[str, str], dict] = {}
    for o in observers:
        if o["design"] == "identification":
            continue
        estimates = [row[3] for row in o["track"] if row[3] is not None]
        assert estimates, f"{o['task']}/{o['condition']}: participant {o['participant']} has no estimate"
        part = by_id[o["task"]]
        group = groups.setdefault((o["task"], o["condition"]), {"values": [], "truths": [], "part": part})
        group["values"].append(trial_counts.measure_of(part, estimates[-1]))
        group["truths"].append(trial_counts.measure_of(part, target_truth(observers_of, o, part, model)))
    return groups


def within_truth(values, truths, method_bias: float = 0.0, comparisons: int = 1) -> tuple[bool, str]:
    """The group's mean recovery error against the truth's 95 % interval: t on n − 1 degrees of
    freedom of the errors' SD, widened by the procedure's own bias (`method_bias`, measured by
    procedure_errors: what a fixed-step staircase gives these observers on average, engine or not).
    With `comparisons` > 1 the intervals are simultaneous (Bonferroni): 95 % that every one of the
    module's parts and conditions holds its truth, where 24 separate 95 % intervals would miss one
    by chance in most runs (1 − 0.95^24 = 71 %)."""
    values, truths = np.asarray(values, float), np.asarray(truths, float)
    n = len(values)
    errors = values - truths
    half = student_t.ppf(1 - 0.025 / comparisons, n - 1) * errors.std(ddof=1) / math.sqrt(n) + abs(method_bias)
    ok = abs(errors.mean()) <= half and abs(values.mean() - truths.mean()) <= half
    return ok, (f"recovered {values.mean():.3f}, true {truths.mean():.3f} ± {half:.3f} (95 %"
                f"{' simultaneous' if comparisons > 1 else ''}, the procedure's "
                f"own bias {method_bias:+.3f} included), mean error {errors.mean():+.3f}, n {n}")


def procedure_errors(text: str, task: str, condition: str, observers_of, part, model: str,
                     runs: int = BIAS_RUNS) -> np.ndarray:
    """The procedure's own errors on these observers: the task's procedure (as in the simulated
    file) run `runs` times per participant without the engine (the engine's level is a pure
    function of the answers: the same procedure; server/simulate/battery_trial_counts.py runs it), each
    answered by the participant's own observer, against the same truth as target_truth's."""
    table = tomllib.loads(text)
    procedure = next(t for t in table["tasks"] if t["id"] == task)["psychophysics"]["procedure"]
    if condition != "main":
        procedure = procedure["conditions"][condition]
    carrier = float(condition[1:]) if condition.startswith("f") else profile_by_model(model).carrier_hz
    errors = trial_counts.staircase_errors(part, procedure, {"carrier_hz": carrier}, (procedure["max_trials"],),
                                           observers_of, PARTICIPANTS, SEED, condition, runs=runs)
    return errors[:, 0]  # [participant · runs + run]: each participant's runs together


def same_spread(engine_errors, free_errors, comparisons: int, draws: int = 4000) -> tuple[bool, str]:
    """The engine's per-participant error SD against the engine-free runs' (the power analysis's
    SE, server/simulate/battery_trial_counts.py): how often 12 errors drawn from the engine-free
    runs, one of each participant's own runs, have an SD as far out as the engine's (two-sided, at
    0.05 / comparisons: Bonferroni over every part and condition of the module). A resampling
    test, not an F test: a staircase's errors are heavy-tailed (an early lapse sends a track the
    wrong way for many trials), which an F test of variances does not tolerate."""
    a = np.asarray(engine_errors, float)
    b = np.asarray(free_errors, float).reshape(len(a), -1)
    rng = np.random.default_rng(SEED)
    picks = b[np.arange(len(a)), rng.integers(0, b.shape[1], (draws, len(a)))]
    sds = picks.std(axis=1, ddof=1)
    sd = a.std(ddof=1)
    p = min(1.0, 2 * min(np.mean(sds <= sd), np.mean(sds >= sd)))
    return p > 0.05 / comparisons, (f"engine SD {sd:.3f}, engine-free SE {b.std(ddof=1):.3f} (its 12-participant "
                                    f"SD's middle 95 %: {np.percentile(sds, 2.5):.3f}–{np.percentile(sds, 97.5):.3f}, "
                                    f"p {p:.3g})")


def check_staircase_parts(model, text, observers, people) -> list[str]:
    def observers_of(index):
        return people.participant(SEED, index).psychometric

    groups = recovered(observers, observers_of, model)
    plans = {p.part.id: p for p in plan_for(model) if p.runs and p.part.measure != "it_bits"
             and p.part.id != "positioning"}
    expected = {(pid, c) for pid, p in plans.items() for c in (p.conditions or ("main",))}
    assert set(groups) == expected, f"parts recovered {sorted(groups)} != planned {sorted(expected)}"
    failures = []
    for key, group in sorted(groups.items()):
        assert len(group["values"]) == PARTICIPANTS, key
        free = procedure_errors(text, key[0], key[1], observers_of, group["part"], model)
        ok, summary = within_truth(group["values"], group["truths"], float(np.nanmean(free)), COMPARISONS)
        spread_ok, spread = same_spread(np.subtract(group["values"], group["truths"]), free, COMPARISONS)
        print(f"{model} {key[0]}/{key[1]}: {summary}; {spread}")
        if not (ok and spread_ok):
            failures.append(f"{key[0]}/{key[1]}: {summary}; {spread}")
    return failures


def identification_check(db: Path, people) -> tuple[float, float, tuple[float, float]]:
    """(the recovered pooled IT, the observers' exact IT (mean), the estimate's 95 % interval over
    REPLICATIONS experiments of the same size by the same observers)."""
    from server.battery.parts import ANGLES_DEG

    con = sqlite3.connect(db)
    try:
        rows = con.execute("""SELECT s.participant_index, t.metrics_json FROM trials t JOIN sessions s
                              ON s.id = t.session_id WHERE t.status = 'answered' AND t.kind = 'main'
                              AND t.task = 'angle_identification'""").fetchall()
    finally:
        con.close()
    k = len(ANGLES_DEG)
    confusion = np.zeros((k, k))
    trials: dict[int, int] = {}
    for index, metrics in rows:
        psy = json.loads(metrics)["psy"]
        confusion[psy["stimulus_index"], psy["answer_index"]] += 1
        trials[index] = trials.get(index, 0) + 1
    assert len(trials) == PARTICIPANTS
    got = information.information_transfer(confusion).corrected
    # the truth: each observer's confusion probabilities (the exact ones its identify draws from) ...
    psy = {"parameter": "contact_angle_deg", "choices": [f"{a:g}" for a in ANGLES_DEG],
           "stimuli": list(ANGLES_DEG)}
    p = {i: people.participant(SEED, i).psychometric.confusion(psy) for i in trials}
    rng = derive_rng("battery-it-truth", SEED)
    exact = float(np.mean([information.from_distribution(q) for q in p.values()]))
    # ... and the estimate over repeated experiments of the same size (per observer, its trials spread evenly)
    sampled = []
    for _ in range(REPLICATIONS):
        c = np.zeros((k, k))
        for i, n in trials.items():
            for s in range(k):
                c[s] += rng.multinomial(n // k, p[i][s])
        sampled.append(information.information_transfer(c).corrected)
    low, high = np.percentile(sampled, [2.5, 97.5])
    return got, exact, (float(low), float(high))


def test_the_reduced_battery_recovers_every_devices_truths(battery):
    model, text, result, observers, people = battery
    print(f"{model}: {result.trials} trials of {PARTICIPANTS} participants in {WALL_S[model]:.0f} s wall "
          f"({result.virtual_s:.0f} s virtual), {WORKERS} workers")
    failures = check_staircase_parts(model, text, observers, people)
    assert not failures, "\n".join(failures)


def test_information_transfer_within_its_truths_interval(battery):
    model, text, result, observers, people = battery
    plan = {p.part.id: p for p in plan_for(model)}["angle_identification"]
    if not plan.runs:
        assert plan.reason and not any(o["design"] == "identification" for o in observers)
        return
    got, exact, (low, high) = identification_check(result.data_dir / "viestac.sqlite", people)
    print(f"{model} angle_identification: IT {got:.3f} bits; truth {exact:.3f} bits, its estimate's 95 % "
          f"interval at this size [{low:.3f}, {high:.3f}]")
    assert low <= got <= high


@pytest.mark.slow
@pytest.mark.skipif(os.environ.get("VIESTAC_FULL_BATTERY") != "1",
                    reason="the full battery files take many minutes a device: VIESTAC_FULL_BATTERY=1 runs them")
@pytest.mark.parametrize("model", BUILT_IN)
def test_the_full_battery_recovers_its_truths(model, tmp_path):
    """The checked-in battery file as it is (every part at its full trial count, positioning too)."""
    text = battery_study(model)
    result, observers, people = simulate(model, text, tmp_path)
    print(f"{model} (full): {result.trials} trials of {PARTICIPANTS} participants in {WALL_S[model]:.0f} s wall "
          f"({result.virtual_s:.0f} s virtual), {WORKERS} workers")
    failures = check_staircase_parts(model, text, observers, people)
    assert not failures, "\n".join(failures)
    if any(p.runs for p in plan_for(model) if p.part.id == "angle_identification"):
        got, exact, (low, high) = identification_check(result.data_dir / "viestac.sqlite", people)
        print(f"{model} angle_identification (full): IT {got:.3f} bits; truth {exact:.3f}, [{low:.3f}, {high:.3f}]")
        assert low <= got <= high
