"""`viestac study --simulate` (issue 7): a study file run by synthetic participants through the
real loop core, the experiment engine and recorder, and the device firmware on the virtual clock."""

import json
import sqlite3
import subprocess
import sys
import textwrap

import pytest

from server.simulate.effects import parse_settings
from server.simulate.study_run import simulate_study
from server.synthetic import SyntheticParticipant

SMALL = textwrap.dedent("""
    id = "sim-small"
    title = "A small study for the simulator"
    seed = 5
    participants = 2

    [[tasks]]
    id = "angles"
    scenario = "contact-angle"
    device = "ferrovibe"
    subtask = "angles"
    practice = 1
    training_s = 2.0

    [[tasks]]
    id = "production"
    scenario = "stiffness"
    device = "fingertac"
    subtask = "production"
    conditions = [{ mode = "production", level = 3 }, { mode = "production", level = 8 }]

    [[tasks]]
    id = "patterns"
    scenario = "positioning"
    device = "fingertac"
    conditions = [{ object = "cube_a", cue = "P1" }, { object = "sphere", cue = "3dof" }]

    [[tasks.questions]]
    id = "helpfulness"
    kind = "likert"
    text = "How much did the tactile cues help?"
""")


def participant(seed, index):
    return SyntheticParticipant(seed, participant=index)


def rows(db, sql):
    con = sqlite3.connect(db)
    try:
        return con.execute(sql).fetchall()
    finally:
        con.close()


@pytest.fixture
def study_file(tmp_path):
    path = tmp_path / "studies" / "sim-small.toml"
    path.parent.mkdir()
    path.write_text(SMALL)
    return path


def test_a_simulated_study_records_every_trial_answer_and_metric(study_file, tmp_path):
    result = simulate_study(study_file, participants=2, seed=11, out_dir=tmp_path / "a", make_participant=participant)
    db = result.data_dir / "viestac.sqlite"
    assert result.aborted == [] and len(result.sessions) == 2
    statuses = rows(db, "SELECT status, COUNT(*) FROM trials GROUP BY status")
    assert statuses == [("answered", result.trials)]
    answers = rows(db, "SELECT t.task, r.question FROM responses r JOIN trials t ON t.id = r.trial_id")
    assert {q for _, q in answers} == {"answer_deg", "helpfulness"}
    metrics = {(task, json.loads(params)["level"] if "level" in params else json.loads(params).get("cue")):
               json.loads(m) for task, params, m in rows(db, "SELECT task, params_json, metrics_json FROM trials "
                                                              "WHERE kind = 'main' AND task != 'angles'")}
    assert metrics[("production", 3)]["target_level"] == 3 and 1 <= metrics[("production", 3)]["produced_level"] <= 10
    assert metrics[("patterns", "P1")]["completion_s"] > 2 and metrics[("patterns", "3dof")]["path_length"] > 0
    samples = rows(db, "SELECT COUNT(*), COUNT(held) FROM samples")[0]
    assert samples[0] > 500 and samples[1] > 100, "trajectories, with the carried object, at 100 Hz"
    created = rows(db, "SELECT created_utc FROM sessions ORDER BY participant")
    assert [c[:10] for (c,) in created] == ["2026-01-05", "2026-01-06"], "virtual time stamps"


def test_the_same_seed_gives_the_same_data(study_file, tmp_path):
    a = simulate_study(study_file, participants=1, seed=3, out_dir=tmp_path / "a", make_participant=participant)
    b = simulate_study(study_file, participants=1, seed=3, out_dir=tmp_path / "b", make_participant=participant)
    query = ("SELECT t.seq, t.status, t.metrics_json, t.started_utc, r.question, r.value_json FROM trials t "
             "LEFT JOIN responses r ON r.trial_id = t.id ORDER BY t.seq, r.question")
    assert rows(a.data_dir / "viestac.sqlite", query) == rows(b.data_dir / "viestac.sqlite", query)
    with pytest.raises(FileExistsError, match="empty directory"):
        simulate_study(study_file, participants=1, seed=3, out_dir=tmp_path / "a", make_participant=participant)


def test_the_cli_shows_progress_and_refuses_bad_input(study_file, tmp_path):
    done = subprocess.run([sys.executable, "-m", "server.cli", "study", "--simulate", "--study", str(study_file),
                           "--participants", "1", "--seed", "1", "--out", str(tmp_path / "c"), "--no-analysis"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "trials of 1 synthetic participants" in done.stdout and "0 aborted" in done.stdout
    assert "[" in done.stderr and "trials ·" in done.stderr, "a progress bar"
    bad = subprocess.run([sys.executable, "-m", "server.cli", "study", "--simulate", "--participants", "0",
                          "--out", str(tmp_path / "d")], capture_output=True, text=True)
    assert bad.returncode == 2 and "at least 1" in bad.stderr


def logical_dump(db):
    """Every row of every table in id (or key) order, session ids replaced by the participant code
    (they are random per run, uuid4): what the data say, whatever wrote the file."""
    con = sqlite3.connect(db)
    try:
        code = dict(con.execute("SELECT id, participant FROM sessions"))
        tables = [t for (t,) in con.execute("SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name")]
        dump = {}
        for table in tables:
            keyed = table in ("samples", "cues", "point_samples")
            rows = con.execute(f"SELECT * FROM {table} ORDER BY {'trial_id, attempt, tick' if keyed else 'rowid'}")
            dump[table] = [tuple(code.get(v, v) if isinstance(v, str) else v for v in row) for row in rows]
        return dump
    finally:
        con.close()


def test_participants_in_two_processes_write_the_rows_one_process_writes(study_file, tmp_path):
    # the CLI's population (its models hold mapping proxies, which do not pickle) with an effect setting
    people = parse_settings(["agent.ferrovibe.duration_scale=1.1", "estimation.b=0.9"])
    run = dict(participants=3, seed=11, make_participant=people.participant, agent_params=people.agent,
               settings=people.settings)
    one = simulate_study(study_file, out_dir=tmp_path / "one", **run)
    seen, freed = [], []
    two = simulate_study(study_file, out_dir=tmp_path / "two", workers=2,
                         progress=lambda done, total, label: seen.append((done, total, label[:5])),
                         on_cpu_free=lambda: freed.append(len(seen)), **run)
    a, b = logical_dump(one.data_dir / "viestac.sqlite"), logical_dump(two.data_dir / "viestac.sqlite")
    assert len(a["sessions"]) == 3 and len(a["samples"]) > 1000 and len(a["events"]) > 100
    assert a == b, "every table, row for row, in the same order and with the same ids"
    assert (two.trials, two.aborted, two.virtual_s) == (one.trials, one.aborted, one.virtual_s)
    assert [s for s in two.sessions] == [s for (s,) in rows(two.data_dir / "viestac.sqlite",
                                                          "SELECT id FROM sessions ORDER BY participant")]
    assert [d for d, _, _ in seen] == list(range(1, one.trials + 1)) and {t for _, t, _ in seen} == {one.trials}
    assert sorted(p.name for p in two.data_dir.iterdir()) == ["viestac.sqlite"], "no scratch databases left"
    # once, when one participant is left for two workers: after the first two have finished
    assert len(freed) == 1 and 2 * one.trials // 3 <= freed[0] < one.trials, (freed, one.trials)
