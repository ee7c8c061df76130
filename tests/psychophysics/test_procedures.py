"""Procedures: the next stimulus is a pure function of (spec, seed, answers); replaying the
recorded answers gives the identical state; the staircase rules, scales, bounds and stops."""

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from server.psychophysics.observer import PsychometricObserver
from server.psychophysics.procedures import next_level, parse_procedure, replay, start

ROOT = Path(__file__).resolve().parents[2]
OBSERVER = PsychometricObserver(threshold=10.0, slope=0.3, guess=0.5, lapse=0.02, family="gumbel")

SPECS = {
    "constant": {"kind": "constant", "levels": [2, 6, 10, 14, 18], "repeats": 4},
    "up-down": {"kind": "up-down", "start": 20.0, "steps": [4, 2, 1], "max_reversals": 10, "min": 0.0, "max": 24.0},
    "weighted": {"kind": "weighted-up-down", "target": 0.75, "guess": 0.5, "start": 20.0, "steps": [2, 1],
                 "max_trials": 40},
    "db": {"kind": "up-down", "scale": "db", "start": 1.0, "steps": [6, 3], "max_trials": 30, "min": 0.01},
    "ladder": {"kind": "up-down", "scale": "ladder", "levels": [1, 2, 4, 8, 16, 32], "steps": [1],
               "max_trials": 25, "down": 3},
    "quest-plus": {"kind": "quest-plus", "family": "gumbel", "levels": {"from": 0, "to": 20, "count": 21},
                   "threshold": {"from": 0, "to": 20, "count": 21}, "slope": [0.15, 0.3, 0.6], "lapse": [0, 0.04],
                   "max_trials": 20, "focus": ["threshold"]},
    "interleaved": {"kind": "interleaved", "conditions": {
        "low": {"kind": "up-down", "start": 20.0, "steps": [4, 2], "max_trials": 12},
        "high": {"kind": "weighted-up-down", "target": 0.8, "guess": 0.5, "start": 15.0, "steps": [1],
                 "max_trials": 9}}},
}


def play(spec, seed, rng):
    """Run against the observer: the levels presented, the answers, the record after every trial."""
    procedure = start(spec, seed)
    levels, answers, records = [], [], []
    while not procedure.finished:
        level = procedure.level
        answer = bool(rng.random() < OBSERVER.probability(level))
        procedure.update(answer)
        levels.append(level)
        answers.append(answer)
        records.append(json.loads(json.dumps(procedure.record())))  # plain, serialisable data
    return levels, answers, records


@pytest.mark.parametrize("name", SPECS)
def test_replaying_the_recorded_answers_gives_the_identical_state(name):
    spec = parse_procedure(SPECS[name])
    levels, answers, records = play(spec, 7, np.random.default_rng(11))
    assert levels and records[-1]["finished"]
    for i in range(len(answers)):
        assert next_level(spec, answers[:i], 7) == levels[i]
        assert json.loads(json.dumps(replay(spec, answers[: i + 1], 7).record())) == records[i]
    assert next_level(spec, answers, 7) is None
    with pytest.raises(ValueError, match="finished"):
        replay(spec, answers, 7).update(True)


def test_seeds_change_only_what_is_random():
    constant = parse_procedure(SPECS["constant"])
    assert start(constant, 1).order != start(constant, 2).order
    assert start(constant, 1).order == start(constant, 1).order
    staircase = parse_procedure(SPECS["up-down"])
    assert start(staircase, 1).record() == start(staircase, 2).record()


def test_constant_stimuli_present_every_level_repeats_times():
    spec = parse_procedure({**SPECS["constant"], "order": "blocked"})
    order = start(spec, 3).order
    assert sorted(order) == sorted(list(range(5)) * 4)
    for block in range(4):
        assert sorted(order[block * 5:(block + 1) * 5]) == list(range(5))
    procedure = replay(spec, [True] * 20, 3)
    assert procedure.record()["counts"] == [[lv, 4, 4] for lv in (2.0, 6.0, 10.0, 14.0, 18.0)]


def test_one_up_two_down_steps_reversals_and_step_sizes():
    spec = parse_procedure({"kind": "up-down", "start": 10.0, "steps": [4, 2, 1], "max_trials": 20})
    p = start(spec)
    track = []
    for answer in [1, 1, 1, 1, 0, 0, 1, 1, 0]:
        track.append(p.level)
        p.update(answer)
    # two correct: down 4; two more: down 4; a wrong one: up, a reversal, so already the second
    # step (2); up 2 again; two correct: down, the second reversal, step 1... after the third, 1 stays
    assert track == [10.0, 10.0, 6.0, 6.0, 2.0, 4.0, 6.0, 6.0, 5.0]
    assert p.record()["reversals"] == [2.0, 6.0, 5.0]
    assert p.level == 6.0  # the third reversal's step is the last one, 1


def test_bounds_clamp_and_are_counted():
    spec = parse_procedure({"kind": "up-down", "start": 3.0, "steps": [2], "min": 0.0, "max": 4.0, "max_trials": 10})
    p = replay(spec, [1, 1, 1, 1, 0, 0, 0])
    assert p.level == 4.0 and p.record()["clamped"] == 2  # 3 → 1 → 0 (clamped from −1); 0 → 2 → 4 → 4 (from 6)


def test_stop_after_reversals_or_trials_whichever_first():
    spec = parse_procedure({"kind": "up-down", "down": 1, "start": 5.0, "steps": [1], "max_reversals": 3,
                            "max_trials": 100})
    p = replay(spec, [1, 0, 1, 0])
    assert p.finished and len(p.reversals) == 3 and p.trial == 4
    spec = parse_procedure({"kind": "up-down", "down": 1, "start": 5.0, "steps": [1], "max_reversals": 3,
                            "max_trials": 2})
    assert replay(spec, [1, 1]).finished


def test_log_db_and_ladder_scales_step_and_average_on_their_own_axis():
    log = parse_procedure({"kind": "up-down", "down": 1, "scale": "log", "start": 8.0, "steps": [2], "max_trials": 9})
    assert replay(log, [1]).level == pytest.approx(4.0)
    p = replay(log, [1, 0])  # reversal at 4
    assert replay(log, [1, 0, 1]).estimate() == pytest.approx(math.sqrt(4.0 * 8.0))  # geometric mean
    assert p.level == pytest.approx(8.0)
    db = parse_procedure({"kind": "up-down", "down": 1, "scale": "db", "start": 1.0, "steps": [6], "max_trials": 9})
    assert replay(db, [1]).level == pytest.approx(10 ** (-6 / 20))
    ladder = parse_procedure(SPECS["ladder"])
    assert replay(ladder, [1, 1, 1]).level == 4.0 and replay(ladder, [0]).level == 16.0
    assert replay(ladder, [0, 0, 0, 0]).level == 32.0 and replay(ladder, [0, 0, 0, 0]).record()["clamped"] == 2
    assert replay(ladder, [0, 1, 1, 1]).estimate() == 16.0  # one reversal, at the rung of 16


def test_harder_higher_moves_the_other_way():
    spec = parse_procedure({"kind": "up-down", "down": 1, "start": 5.0, "steps": [1], "harder": "higher",
                            "max_trials": 5})
    assert replay(spec, [1]).level == 6.0 and replay(spec, [0]).level == 4.0


def test_weighted_steps_keep_the_target_ratio():
    spec = parse_procedure({"kind": "weighted-up-down", "target": 0.9, "guess": 0.5, "start": 10.0, "steps": [1],
                            "max_trials": 5})
    assert replay(spec, [1]).level == pytest.approx(9.0) and replay(spec, [0]).level == pytest.approx(19.0)


def test_interleaving_is_seeded_uniform_and_runs_every_condition_to_its_end():
    spec = parse_procedure(SPECS["interleaved"])
    _, answers, records = play(spec, 5, np.random.default_rng(2))
    assert len(answers) == 12 + 9
    final = records[-1]["procedures"]
    assert final["low"]["trial"] == 12 and final["high"]["trial"] == 9
    firsts = {start(spec, seed).condition for seed in range(20)}
    assert firsts == {"low", "high"}
    stim = start(spec, 0).stimulus
    assert stim["condition"] in ("low", "high") and "level" in stim


def test_procedures_run_without_scipy():
    """The procedures (QUEST+ on a normal family included) need numpy alone: a server without
    the analysis extra runs them, with the same numbers."""
    code = """
import sys, json
sys.modules["scipy"] = None  # any import of scipy fails
from server.psychophysics.procedures import parse_procedure, replay
from server.psychophysics.functions import NORMAL
spec = parse_procedure({"kind": "quest-plus", "family": "normal", "levels": [-2, -1, 0, 1, 2],
                        "threshold": [-1, 0, 1], "slope": [1, 2], "guess": 0, "lapse": 0, "max_trials": 4})
q = replay(spec, [True, False])
print(json.dumps({"level": q.level, "est": q.estimates(), "cdf": NORMAL.sigmoid([-1.0, 0.0, 2.5]).tolist()}))
"""
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    without = json.loads(out.stdout)
    from scipy.special import ndtr
    spec = parse_procedure({"kind": "quest-plus", "family": "normal", "levels": [-2, -1, 0, 1, 2],
                            "threshold": [-1, 0, 1], "slope": [1, 2], "guess": 0, "lapse": 0, "max_trials": 4})
    q = replay(spec, [True, False])
    assert without["level"] == q.level
    assert without["est"] == pytest.approx(q.estimates(), abs=1e-12)
    assert without["cdf"] == pytest.approx(ndtr([-1.0, 0.0, 2.5]).tolist(), abs=1e-15)
