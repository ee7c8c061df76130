"""The speed work on the tick and the virtual rig must not change one recorded number: one
simulated thesis participant gives, table for table and row for row, the database the code before
it gave (tests/vectors/study_digest.json, made by tests/vectors/make_study_digest.py at 2d3af1a)."""

import json

from tests.vectors.make_study_digest import HERE, PARTICIPANTS, SEED, STUDY, simulate, table_digests


def test_a_simulated_thesis_participant_records_what_the_code_before_the_speed_work_recorded(tmp_path):
    expected = json.loads((HERE / "study_digest.json").read_text())
    assert (expected["study"], expected["seed"], expected["participants"]) == (STUDY, SEED, PARTICIPANTS)
    got = table_digests(simulate(tmp_path))
    assert got["samples"][0] > 30_000 and got["cues"][0] > 50_000, "a whole participant ran"
    differ = {t: (got.get(t), v) for t, v in expected["tables"].items() if got.get(t) != v}
    assert not differ, f"tables that differ (rows, sha256) now vs before: {differ}"
