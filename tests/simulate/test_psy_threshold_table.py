"""The threshold table of `study --power` for psychophysics (server/simulate/threshold_power.py):
the SE of each participant's threshold estimate at every trial count, the smallest count meeting
the target, constant stimuli estimated by a fit. Tracks here come from the production procedures
answered by the psychometric participant, in the shape the engine's records give
(`tracks()` reads the same from a simulated study: tests/simulate/test_psy_study_run.py)."""

from __future__ import annotations

import textwrap

import pytest

from server.psychophysics.procedures import parse_procedure, start
from server.simulate.threshold_power import (default_trials, estimate_at, psychophysics_tasks, run_threshold_power,
                                             threshold_table)
from server.synthetic.psychometric import PsychometricModel
from server.synthetic.rng import derive_rng

STAIRCASE = {"kind": "up-down", "scale": "db", "start": 50.0, "steps": [4, 2], "min": 0.05, "max": 100.0,
             "max_trials": 80, "average": 6}
CONSTANT = {"kind": "constant", "levels": [1.0, 2.0, 4.0, 8.0, 16.0, 32.0], "repeats": 10}


def observer_track(spec_table, index, task="detect"):
    """One participant's 2IFC detection track as the engine records it: [t, level, correct, estimate]."""
    person = PsychometricModel().participant(4, index)
    rng = derive_rng("table", task, index)
    procedure, track = start(parse_procedure(spec_table), 0), []
    while not procedure.finished:
        target = int(rng.integers(1, 3))
        psy = {"design": "2ifc", "parameter": "intensity_pct", "level": procedure.level, "reference": None,
               "target": target, "choices": ["1", "2"]}
        correct = person.answer(psy, rng) == str(target)
        level = procedure.level
        procedure.update(correct)
        track.append([len(track) + 1, level, correct, procedure.estimate()])
    return {"participant": index, "task": task, "condition": "main", "design": "2ifc", "parameter": "intensity_pct",
            "unit": "%", "guess": 0.5, "true": person.threshold("intensity_pct", None), "track": track}


@pytest.fixture(scope="module")
def staircases():
    return [observer_track(STAIRCASE, i) for i in range(60)]


def test_the_se_falls_with_trials_and_the_target_is_met_at_the_first_count_that_meets_it(staircases):
    table = threshold_table(staircases, [20, 40, 80], target_se_db=100.0)
    rows = {r["trials"]: r for r in table["rows"]}
    assert [rows[t]["observers"] for t in (20, 40, 80)] == [60, 60, 60]
    assert rows[80]["estimated"] == 60 and rows[80]["scale"] == "dB"
    assert rows[80]["se"] < rows[40]["se"] < rows[20]["se"]
    low, high = rows[80]["se_ci95"]
    assert low < rows[80]["se"] < high
    assert rows[80]["rmse"] ** 2 == pytest.approx(rows[80]["bias"] ** 2 + rows[80]["se"] ** 2 * 59 / 60, rel=1e-6)
    assert table["summary"] == [{"task": "detect", "condition": "main", "parameter": "intensity_pct", "scale": "dB",
                                 "target_se": 100.0, "trials_for_target": 20}]
    target = rows[40]["se"] + 1e-9  # met at 40, not at 20
    assert threshold_table(staircases, [20, 40, 80], target)["summary"][0]["trials_for_target"] == 40
    assert threshold_table(staircases, [20, 40, 80], 1e-3)["summary"][0]["trials_for_target"] is None


def test_the_staircase_estimate_is_read_at_each_count_and_counts_stay_separate_per_condition(staircases):
    one = staircases[0]
    assert estimate_at(one, 80) == one["track"][79][3]
    assert estimate_at(one, 1) is None  # no reversal yet: no estimate, no error counted
    other = {**staircases[1], "condition": "f100"}
    table = threshold_table([one, other], [80])
    assert [(r["condition"], r["observers"]) for r in table["rows"]] == [("f100", 1), ("main", 1)]


def test_constant_stimuli_are_estimated_by_a_fit_of_the_first_trials():
    observers = [observer_track(CONSTANT, i, task="constant") for i in range(25)]
    assert all(row[3] is None for row in observers[0]["track"])  # the procedure itself estimates nothing
    rows = {r["trials"]: r for r in threshold_table(observers, [30, 60])["rows"]}
    assert rows[60]["estimated"] >= 20
    assert abs(rows[60]["bias"]) < 3.0 and rows[60]["se"] < 6.0  # dB: the fit recovers α (Weibull = model)


def test_the_psychophysics_tasks_and_the_default_grid_come_from_the_file():
    text = textwrap.dedent("""
        id = "x"
        [[tasks]]
        id = "angles"
        scenario = "contact-angle"
        [[tasks]]
        id = "detect"
        scenario = "stimulus"
        [tasks.psychophysics]
        design = "2ifc"
        max_trials = 60
    """)
    assert psychophysics_tasks(text) == {"detect": 60}
    assert default_trials(60) == [15, 30, 45, 60]
    assert default_trials(2) == [1, 2]


def test_a_study_without_psychophysics_is_refused_before_any_work(tmp_path):
    study = tmp_path / "plain.toml"
    study.write_text('id = "plain"\ntitle = "t"\nseed = 1\nparticipants = 2\n[[tasks]]\nid = "angles"\nscenario = "contact-angle"\n'
                     'device = "ferrovibe"\nsubtask = "angles"\n', encoding="utf-8")
    with pytest.raises(ValueError, match=r"no task has a \[tasks.psychophysics\] table"):
        run_threshold_power(study, 2, 1, out=tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_the_command_takes_a_psychophysics_study_to_the_threshold_run(tmp_path, capsys):
    """`viestac study --power` on a file with [tasks.psychophysics] asks for one group size and
    trial counts, and says what is wrong before any simulation."""
    from server.cli import main

    study = tmp_path / "psy.toml"
    study.write_text('id = "psy"\ntitle = "t"\nseed = 1\nparticipants = 2\n[[tasks]]\nid = "detect"\n'
                     'scenario = "stimulus"\n[tasks.psychophysics]\ndesign = "2ifc"\nmax_trials = 20\n',
                     encoding="utf-8")
    out = tmp_path / "out"
    assert main(["study", "--power", "--study", str(study), "--participants", "4,8", "--out", str(out)]) == 2
    assert "give one number of --participants (the trial counts are --trials)" in capsys.readouterr().err
    assert main(["study", "--power", "--study", str(study), "--trials", "10,x", "--out", str(out)]) == 2
    assert "--trials takes whole numbers" in capsys.readouterr().err
    assert not out.exists()


def test_the_threshold_options_on_a_study_without_psychophysics_are_refused(tmp_path, capsys):
    from server.cli import main

    study = tmp_path / "plain.toml"
    study.write_text('id = "plain"\ntitle = "t"\nseed = 1\nparticipants = 2\n[[tasks]]\nid = "angles"\n'
                     'scenario = "contact-angle"\ndevice = "ferrovibe"\nsubtask = "angles"\n', encoding="utf-8")
    out = tmp_path / "out"
    assert main(["study", "--power", "--study", str(study), "--target-se-db", "0.5", "--out", str(out)]) == 2
    assert "--trials and --target-se-db are for a psychophysics study" in capsys.readouterr().err
    assert not out.exists()
