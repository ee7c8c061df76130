"""The battery's default trial counts come from the power analysis (issue 38 point 1,
docs/battery.md "Trial counts"): server/simulate/battery_trial_counts.py runs each part's procedure
without the engine for the literature's synthetic observers, and parts.TRIALS is what it derives;
a lab changes a count or a target from the command line, and bad values are refused by name."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import chisquare

from server.simulate import battery_trial_counts as trial_counts
from server.battery.parts import BY_ID, PARTS, TRIALS, plan_for
from server.battery.study_file import battery_study
from server.synthetic.psychometric import LITERATURE
from server.synthetic.rng import derive_rng

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def derived():
    return trial_counts.derive()


def test_the_default_trial_counts_are_the_power_analysis(derived):
    counts, rows = derived
    assert set(counts) == {p.id for p in PARTS if p.id != "positioning"}
    assert {k: c.trials for k, c in counts.items()} == {k: TRIALS[k] for k in counts}, \
        "parts.TRIALS is not what `viestac battery --trial-counts` derives: update it from that output"
    for part_id, count in counts.items():
        assert count.met, f"{part_id}: its target SE {count.target_se} is not met on the grid"
        # the count is the smallest of the grid at which every condition meets the target
        mine = [r for r in rows if r.part == part_id]
        at = [r for r in mine if r.trials == count.trials]
        assert at and all(r.se <= count.target_se for r in at)
        below = [g for g in trial_counts.GRID if g < count.trials]
        if below:
            assert any(r.se > count.target_se for r in mine if r.trials == below[-1])


def test_more_trials_shrink_the_error_until_the_staircase_has_converged(derived):
    """The analysis behaves as a staircase does: far from converged at the grid's smallest count
    (large SE), within its target at the chosen count, and nearly unbiased there (the estimate is
    the mean of the last reversals, which stops improving once the track oscillates about its
    target: the plateau is why the counts stop where they do)."""
    counts, rows = derived
    for part_id, count in counts.items():
        for condition in {r.condition for r in rows if r.part == part_id}:
            mine = {r.trials: r for r in rows if r.part == part_id and r.condition == condition}
            first = mine[min(mine)]
            chosen = mine[count.trials]
            assert first.se > 1.2 * chosen.se, (part_id, condition, first.se, chosen.se)
            assert abs(chosen.bias) < chosen.se, (part_id, condition, chosen.bias, chosen.se)


def test_an_observers_confusion_is_what_its_identify_draws():
    psy = {"parameter": "contact_angle_deg", "choices": ["-60", "-30", "0", "30", "60"],
           "stimuli": [-60, -30, 0, 30, 60]}
    rng = derive_rng("confusion-check", 1)
    for index in (0, 3, 7):
        person = LITERATURE.participant(5, index)
        p = person.confusion(psy)
        assert np.allclose(p.sum(axis=1), 1.0) and (p > 0).all()
        for s in range(5):
            drawn = np.bincount([person.identify({**psy, "stimulus_index": s}, rng) for _ in range(3000)],
                                minlength=5)
            expected = p[s] * drawn.sum()
            keep = expected >= 5  # chi-square's cells; the rest pooled
            observed = np.append(drawn[keep], drawn[~keep].sum())
            expect = np.append(expected[keep], expected[~keep].sum())
            if observed[-1] == 0 and expect[-1] < 1e-9:
                observed, expect = observed[:-1], expect[:-1]
            assert chisquare(observed, expect).pvalue > 1e-4, (index, s, drawn, expected)


def test_the_analysis_is_seeded():
    part = BY_ID["amplitude_jnd"]
    a = trial_counts.precision(part, (20, 40), observers=20, seed=3)
    b = trial_counts.precision(part, (20, 40), observers=20, seed=3)
    c = trial_counts.precision(part, (20, 40), observers=20, seed=4)
    assert a == b and a != c


def test_count_for_needs_every_condition_to_meet_the_target():
    part = BY_ID["detection"]
    P = trial_counts.Precision
    rows = [P("detection", "f40", 20, 0, 3.0, "dB"), P("detection", "f40", 40, 0, 1.9, "dB"),
            P("detection", "f250", 20, 0, 1.5, "dB"), P("detection", "f250", 40, 0, 2.5, "dB"),
            P("detection", "f250", 60, 0, 1.8, "dB"), P("detection", "f40", 60, 0, 1.7, "dB")]
    count = trial_counts.count_for(part, rows)
    assert (count.trials, count.worst, count.met) == (40, "f40", True)  # the smallest each meets
    missed = trial_counts.count_for(part, [P("detection", "f40", 20, 0, 3.0, "dB"), P("detection", "f40", 40, 0, 2.5, "dB")])
    assert (missed.trials, missed.met) == (40, False)


def test_a_lab_sets_a_count_or_a_target_and_bad_ones_are_refused(tmp_path):
    text = battery_study("ferrovibe", trials={"stiffness": 30, "angle_identification": 25})
    tasks = {t["id"]: t for t in tomllib.loads(text)["tasks"]}
    assert tasks["stiffness"]["psychophysics"]["max_trials"] == 30
    assert tasks["angle_identification"]["psychophysics"]["procedure"]["repeats"] == 5
    assert tasks["tilt_direction"]["psychophysics"]["max_trials"] == TRIALS["tilt_direction"]
    assert "trials set by --trials/--target-se" in text.split("stiffness", 1)[1].split("\n", 1)[0]
    for bad, message in (({"stifness": 30}, "did you mean 'stiffness'"), ({"positioning": 5}, "three objects"),
                         ({"stiffness": 4}, "at least 10"), ({"stiffness": 30.5}, "whole number"),
                         ({"angle_identification": 42}, "multiple of its 5 angles")):
        with pytest.raises(ValueError, match=message):
            plan_for("ferrovibe", bad)
    with pytest.raises(ValueError, match="a standard error above 0"):
        trial_counts.derive(parts=[BY_ID["stiffness"]], targets={"stiffness": 0}, observers=10)

    def cli(*args):
        return subprocess.run([sys.executable, "-m", "server.cli", "battery", *args], capture_output=True, text=True,
                              cwd=ROOT)

    out = tmp_path / "b.toml"
    done = cli("--device", "fingertac", "--out", str(out), "--target-se", "stiffness=0.08", "--observers", "60")
    assert done.returncode == 0, done.stderr
    loose = tomllib.loads(out.read_text(encoding="utf-8"))
    stiffness = next(t for t in loose["tasks"] if t["id"] == "stiffness")["psychophysics"]["max_trials"]
    assert stiffness < TRIALS["stiffness"]  # a looser target needs fewer trials
    for args, message in ((("--device", "fingertac", "--out", str(tmp_path / "x.toml"), "--trials", "stiffness"),
                           "--trials takes PART=N"),
                          (("--trial-counts", "--target-se", "stifness=0.1"), "did you mean 'stiffness'"),
                          (("--out", str(tmp_path / "x.toml")), "--device and --out are required")):
        done = cli(*args)
        assert done.returncode == 2 and message in done.stderr, (args, done.stderr)
    assert not (tmp_path / "x.toml").exists()
    done = cli("--trial-counts", "--observers", "30")
    assert done.returncode == 0 and "stiffness: target SE 0.037 -> " in done.stdout, done.stdout
