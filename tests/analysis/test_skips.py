"""Analyses whose data are absent or too few are skipped cleanly: null in stats.json with a reason,
never an exception or a NaN."""

from __future__ import annotations

import json

import pandas as pd

from server.analysis import task1, task2, task3, task4
from server.analysis.keys import REQUIRED, why_missing
from server.analysis.load import SESSION_COLUMNS, TRIAL_COLUMNS, Dataset, ENDPOINT_COLUMNS
from server.analysis.run import compute
from tests.analysis.test_reference import DEV, angle_frame


def empty_dataset() -> Dataset:
    row = {c: None for c in SESSION_COLUMNS} | {"session": "s1", "study_id": "demo", "study_title": "Demo",
                                                "study_hash": "abc", "participant": "P01", "software_version": "0.1.0"}
    sessions = pd.DataFrame([row], columns=SESSION_COLUMNS)
    return Dataset(sessions, pd.DataFrame(columns=TRIAL_COLUMNS), pd.DataFrame(columns=ENDPOINT_COLUMNS), "x.sqlite")


def test_no_data_at_all_gives_reasons_for_every_required_key():
    stats, _ = compute(empty_dataset())
    json.dumps(stats, allow_nan=False)
    for path in REQUIRED:
        reason = why_missing(stats, path)
        assert reason and reason != "missing", path
    assert stats["task4"]["throughput"] is None and "task4.throughput" in stats["skipped"]


def test_one_participant_has_descriptives_but_no_rm_anova():
    section, skipped = task1.analyze(angle_frame(DEV[:1]))
    assert section["per_angle"][0]["mean"] == DEV[0, 0] and section["per_angle"][0]["ci95_low"] is None
    assert section["rm_anova"] is None and "participants" in skipped["rm_anova"]
    assert section["quadratic_trend"] is not None  # 4 trials at 4 angles: the trend is still defined


def test_a_constant_response_is_skipped_not_nan():
    const = angle_frame(DEV * 0 + 5.0)
    section, skipped = task1.analyze(const)
    assert section["rm_anova"] is None and "does not vary" in skipped["rm_anova"]
    ident = pd.DataFrame([(i, "P1", 250.0, 250.0) for i in range(5)], columns=task2.IDENT_COLUMNS)
    section, skipped = task2.analyze(pd.DataFrame(columns=task2.PAIR_COLUMNS), ident)
    assert section["kendall_tau"] is None and "two different" in skipped["kendall_tau"]


def test_power_fit_needs_levels_inside_the_fit_range():
    only_references = pd.DataFrame([(0, "P1", 1.0, 1.0, None), (1, "P1", 10.0, 9.0, None)], columns=task3.COLUMNS)
    section, skipped = task3.analyze(only_references, pd.DataFrame(columns=task3.COLUMNS))
    assert section["estimation"]["a"] is None and "levels 2..9" in skipped["estimation.fit"]
    assert skipped["estimation.b"] == skipped["estimation.fit"]
    assert section["production"]["per_level"] is None


def test_positioning_without_a_second_device_or_end_points():
    rows = [(i, f"P{i % 4}", "t", "fingertac", cue, "cube_a", 0.0, 1000.0, 4.0 + i % 3, 12.0 + i % 5, 7.0, 0.02,
             0.01, 5.0) for i, cue in enumerate(["P1", "P2", "P3"] * 4)]
    frame = pd.DataFrame(rows, columns=task4.COLUMNS)
    section, skipped, kept = task4.analyze(frame, pd.DataFrame(columns=("participant", "task", "device", "question",
                                                                        "value")))
    assert section["fingertac"]["trajectory_length"]["n_trials"] == 12
    assert section["ferrovibe"] is None and "ferrovibe" in skipped
    assert "comparison" in skipped and "questionnaire" in skipped
    assert section["fingertac"]["rm_anova"]["completion_time"]["within"] == ["cue"]
    assert "no residual variance" in skipped["fingertac.rm_anova.trajectory_length"]  # each cue one length
    from server.analysis.fitts import throughput
    from server.analysis.stats import Skip

    try:
        throughput(kept, pd.DataFrame(columns=ENDPOINT_COLUMNS))
    except Skip as exc:
        assert "samples" in str(exc) and "go events" in str(exc)
    else:
        raise AssertionError("throughput without end points must be skipped")

