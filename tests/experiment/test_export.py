"""`viestac export`: a database built with the Store (trials through their lifecycle, responses,
samples, cues, events) exported as files, by the function and by the CLI, while the Store still
has the database open (as a running server would), and checked cell by cell."""

import csv
import hashlib
import itertools
import json
import os
import subprocess
import sys
from datetime import datetime, timedelta, timezone
from pathlib import Path

import pytest

from server.experiment.export import ExportError, export
from server.experiment.store import Store

ROOT = Path(__file__).resolve().parents[2]
T0 = datetime(2026, 11, 21, 8, 0, 0, tzinfo=timezone.utc)


def clock():
    seconds = itertools.count()
    return lambda: (T0 + timedelta(seconds=next(seconds))).isoformat(timespec="microseconds")


def item(seq, kind, index, params=None, questions=(), condition=None, scenario_params=None):
    return {"seq": seq, "task": "questionnaire" if kind == "questionnaire" else "angles", "kind": kind,
            "index": index, "scenario": "contact-angle-v1",
            "scenario_params": scenario_params or {"magnitude_pct": 100.0, "probe": "hip"},
            "device": "ferrovibe", "params": params or {}, "condition": condition, "repetition": 0,
            "duration_s": 120.0 if kind == "training" else 30.0, "questions": list(questions)}


PLAN = [item(0, "training", 0),
        item(1, "main", 0, {"angle_deg": 10.0}, ["answer_deg"], 0),
        item(2, "main", 1, {"angle_deg": 20.0}, ["answer_deg"], 1),
        item(3, "questionnaire", 0, questions=["comment", "rating"]),
        item(4, "main", 2, {"angle_deg": 30.0}, ["answer_deg"], 2)]
COMMENT = 'felt "odd", then fine\nsecond line'


def sample(tick, held=None):
    return (tick, 0.001 * tick, 0.1, 0.2, 0.001 * tick, 0.1, 0.19, 1 if tick % 20 == 0 else 0, held,
            None if held is None else 0.5, None if held is None else 0.1, None if held is None else -0.01)


def new_session(store, sid, participant, plan):
    store.create_session(session_id=sid, study_id="demo", study_title="Demo", study_hash="abc",
                         study_text='[study]\nid = "demo"\n', participant=participant, participant_index=int(sid[-1]),
                         device="ferrovibe", experimenter="alice", notes="n", software_version="0.1.0",
                         config={"tick_hz": 1000, "record_every": 10}, plan=plan)
    return {t.seq: t.id for t in store.trials(sid)}


def build(store):
    """Session s1: training answered, trial 1 aborted + retried + answered (two attempts with
    samples), trial 2 answered then excluded (no ticks), a questionnaire, trial 4 left running.
    Session s2: one answered trial with other metrics."""
    ids = new_session(store, "s1", "P01", PLAN)
    store.transition(ids[0], "running", tick=0)
    store.transition(ids[0], "answered", tick=120_000)

    store.transition(ids[1], "running", tick=1000)
    store.add_samples(ids[1], 1, [sample(1000), sample(1010)])
    store.add_cues(ids[1], 1, [(1000, [{"kind": "vibration", "intensity_pct": 50.0}])])
    store.put_response(ids[1], "answer_deg", 99, "alice")  # cleared by the retry
    store.transition(ids[1], "aborted", tick=1500, reason="participant asked")
    store.transition(ids[1], "pending")
    store.transition(ids[1], "running", tick=5000)
    store.add_samples(ids[1], 2, [sample(5000), sample(5010, "cube_a"), sample(5020, "cube_a")])
    store.add_cues(ids[1], 2, [(5000, [{"kind": "tilt", "angle_deg": 10.0}]), (5010, [])])
    store.add_events([("s1", ids[1], 2, 5005, "scenario", {"name": "tap", "tick": 5005})])
    store.put_response(ids[1], "answer_deg", 12.5, "participant")
    store.transition(ids[1], "answered", tick=7500, metrics={"rt_s": 2.5, "contacts": 3, "path": [1, 2]})

    store.transition(ids[2], "running")
    store.put_response(ids[2], "answer_deg", 20, "alice")
    store.transition(ids[2], "answered", metrics={"rt_s": 1.25})
    store.transition(ids[2], "excluded", reason="outlier")

    store.transition(ids[3], "running", tick=8000)
    store.put_response(ids[3], "rating", 6, "participant")
    store.put_response(ids[3], "comment", COMMENT, "alice")
    store.transition(ids[3], "answered", tick=8100)

    ids2 = new_session(store, "s2", "P02", [item(0, "main", 0, {"angle_deg": 45.0}, ["answer_deg"], 0)])
    store.transition(ids2[0], "running", tick=100)
    store.put_response(ids2[0], "answer_deg", 40, "alice")
    store.transition(ids2[0], "answered", tick=600, metrics={"errors": 1})
    store.set_session_status("s2", "completed")

    store.add_events([("s1", None, None, None, "control", {"experimenter": "bob"})])
    store.transition(ids[4], "running", tick=9000)
    store.add_samples(ids[4], 1, [sample(9000), sample(9010)])
    return ids


@pytest.fixture
def db(tmp_path):
    """The database, with the Store still holding it open (a running server)."""
    store = Store(tmp_path / "data" / "viestac.sqlite", clock())
    ids = build(store)
    yield store, ids
    store.close()


def read_csv(path):
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def header(path):
    with open(path, newline="", encoding="utf-8") as f:
        return next(csv.reader(f))


def cli(*args, env=None):
    return subprocess.run([sys.executable, "-m", "server.cli", "export", *map(str, args)], cwd=ROOT,
                          capture_output=True, text=True, env={**os.environ, **(env or {})}, timeout=60)


def test_one_session_exports_every_file_with_its_content(db, tmp_path):
    store, ids = db
    out = tmp_path / "out"
    [summary] = export(store.path, out, "s1")
    folder = out / "demo_P01_s1"
    assert summary == {"session": "s1", "dir": str(folder), "trials": 5, "responses": 4, "trajectories": 3,
                       "written": 8, "unchanged": 0, "removed": 0}
    assert sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file()) == [
        "cues.csv", "events.csv", "responses_long.csv", "session.json", "trajectories/trial_1_attempt_1.csv",
        "trajectories/trial_1_attempt_2.csv", "trajectories/trial_4_attempt_1.csv", "trials_wide.csv"]
    assert [p.name for p in out.iterdir()] == ["demo_P01_s1"], "no staging directory left behind"

    # the wide file: one row per trial, session columns first, the groups sorted
    cols = header(folder / "trials_wide.csv")
    assert cols[:8] == ["session", "study", "participant", "participant_index", "device", "experimenter",
                        "software_version", "seq"]
    assert cols[cols.index("trajectory") + 1:] == [
        "param.angle_deg", "scenario.magnitude_pct", "scenario.probe", "response.answer_deg", "response.comment",
        "response.rating", "metric.contacts", "metric.path", "metric.rt_s"]
    wide = read_csv(folder / "trials_wide.csv")
    assert [r["seq"] for r in wide] == ["0", "1", "2", "3", "4"]
    assert all(r["session"] == "s1" and r["participant"] == "P01" and r["study"] == "demo" for r in wide)
    training, t1, t2, quest, t4 = wide
    assert training["status"] == "answered" and training["duration_s"] == "120.0"
    assert training["duration_from"] == "ticks" and training["param.angle_deg"] == ""
    assert training["planned_duration_s"] == "120.0" and training["response.answer_deg"] == ""
    assert (t1["status"], t1["attempt"], t1["started_tick"], t1["ended_tick"]) == ("answered", "2", "5000", "7500")
    assert t1["duration_s"] == "2.5" and t1["param.angle_deg"] == "10.0" and t1["condition"] == "0"
    assert t1["response.answer_deg"] == "12.5", "the retried attempt's answer, not the aborted one's"
    assert (t1["metric.rt_s"], t1["metric.contacts"], t1["metric.path"]) == ("2.5", "3", "[1,2]")
    assert t1["trajectory"] == "trajectories/trial_1_attempt_2.csv" and t1["scenario.magnitude_pct"] == "100.0"
    assert t2["status"] == "excluded" and t2["reason"] == "outlier" and t2["response.answer_deg"] == "20"
    assert t2["started_tick"] == "" and t2["duration_from"] == "utc" and float(t2["duration_s"]) > 0
    assert t2["metric.rt_s"] == "1.25" and t2["metric.contacts"] == "" and t2["trajectory"] == ""
    assert quest["kind"] == "questionnaire" and quest["response.rating"] == "6" and quest["response.comment"] == COMMENT
    assert quest["condition"] == "" and quest["response.answer_deg"] == ""
    assert t4["status"] == "running" and t4["ended_utc"] == "" and t4["duration_s"] == ""

    # the long file: one row per response
    long = read_csv(folder / "responses_long.csv")
    assert [(r["seq"], r["question"], r["value"], r["entered_by"]) for r in long] == [
        ("1", "answer_deg", "12.5", "participant"), ("2", "answer_deg", "20", "alice"),
        ("3", "comment", COMMENT, "alice"), ("3", "rating", "6", "participant")]
    assert long[1]["trial_status"] == "excluded" and long[0]["task"] == "angles" and long[0]["kind"] == "main"
    assert json.loads(long[2]["value_json"]) == COMMENT and long[0]["answered_utc"].startswith("2026-11-21T08:")

    # trajectories, one file per attempt, with their own ticks
    first = read_csv(folder / "trajectories/trial_1_attempt_1.csv")
    second = read_csv(folder / "trajectories/trial_1_attempt_2.csv")
    assert header(folder / "trajectories/trial_1_attempt_2.csv") == [
        "tick", "t_s", "hip_x", "hip_y", "hip_z", "proxy_x", "proxy_y", "proxy_z", "contact", "held", "held_x",
        "held_y", "held_z"]
    assert [r["tick"] for r in first] == ["1000", "1010"] and [r["tick"] for r in second] == ["5000", "5010", "5020"]
    assert [r["t_s"] for r in second] == ["5.0", "5.01", "5.02"]
    assert second[1]["held"] == "cube_a" and second[1]["held_z"] == "-0.01" and second[0]["held"] == ""
    assert second[0]["hip_x"] == "5.0" and second[0]["contact"] == "1" and second[1]["contact"] == "0"
    assert [r["tick"] for r in read_csv(folder / "trajectories/trial_4_attempt_1.csv")] == ["9000", "9010"]

    cues = read_csv(folder / "cues.csv")
    assert [(c["seq"], c["attempt"], c["tick"]) for c in cues] == [("1", "1", "1000"), ("1", "2", "5000"),
                                                                   ("1", "2", "5010")]
    assert json.loads(cues[1]["cues"]) == [{"kind": "tilt", "angle_deg": 10.0}] and cues[2]["cues"] == "[]"
    events = read_csv(folder / "events.csv")
    assert header(folder / "events.csv") == ["seq", "attempt", "tick", "utc", "kind", "body"]
    tap = next(e for e in events if e["kind"] == "scenario")
    assert (tap["seq"], tap["attempt"], tap["tick"], json.loads(tap["body"])) == ("1", "2", "5005",
                                                                                  {"name": "tap", "tick": 5005})
    control = next(e for e in events if e["kind"] == "control")
    assert control["seq"] == "" and control["attempt"] == "" and json.loads(control["body"]) == {"experimenter": "bob"}
    lifecycle = [(e["seq"], json.loads(e["body"])["to"]) for e in events if e["kind"] == "lifecycle"]
    assert lifecycle[:5] == [("0", "running"), ("0", "answered"), ("1", "running"), ("1", "aborted"),
                             ("1", "pending")]
    assert len(events) == len(store.events("s1"))


def test_session_json_holds_the_whole_session(db, tmp_path):
    store, ids = db
    export(store.path, tmp_path / "out", "s1")
    doc = json.loads((tmp_path / "out/demo_P01_s1/session.json").read_text())
    assert doc["format"] == "viestac-session-export" and doc["format_version"] == 1 and doc["tick_hz"] == 1000.0
    session = store.session("s1")
    assert doc["session"] == session, "every column of the session row, the config decoded, the study text"
    assert doc["session"]["study_text"] == '[study]\nid = "demo"\n' and doc["session"]["config"]["record_every"] == 10
    assert [t["seq"] for t in doc["trials"]] == [0, 1, 2, 3, 4]
    for got, want in zip(doc["trials"], store.trials("s1")):
        want = want.to_dict()
        want["planned_duration_s"] = want.pop("duration_s")
        assert {k: got[k] for k in want if k != "session_id"} == {k: v for k, v in want.items() if k != "session_id"}
        assert {q: r["value"] for q, r in got["responses"].items()} == store.responses(want["id"])
    t1 = doc["trials"][1]
    assert t1["metrics"] == {"rt_s": 2.5, "contacts": 3, "path": [1, 2]} and t1["duration_s"] == 2.5
    assert t1["responses"]["answer_deg"]["entered_by"] == "participant"
    assert t1["attempts"] == [
        {"attempt": 1, "samples": 2, "first_tick": 1000, "last_tick": 1010, "cues": 1,
         "trajectory": "trajectories/trial_1_attempt_1.csv"},
        {"attempt": 2, "samples": 3, "first_tick": 5000, "last_tick": 5020, "cues": 2,
         "trajectory": "trajectories/trial_1_attempt_2.csv"}]
    assert doc["trials"][3]["responses"]["comment"]["value"] == COMMENT
    assert [e["kind"] for e in doc["events"]] == [e["kind"] for e in store.events("s1")]


def test_export_while_a_trial_runs_leaves_the_database_alone(db, tmp_path):
    store, ids = db
    files = [store.path, Path(f"{store.path}-wal")]
    before = [hashlib.sha256(p.read_bytes()).hexdigest() for p in files]
    n_events = len(store.events("s1"))
    export(store.path, tmp_path / "out", "s1")
    result = cli("s1", "--out", tmp_path / "out2", "--data-dir", store.path.parent)
    assert result.returncode == 0, result.stderr
    assert "demo_P01_s1" in result.stdout and "5 trials" in result.stdout
    assert store.trial(ids[4]).status == "running" and store.running().id == ids[4], "no crash recovery ran"
    assert store.trial(ids[4]).reason == "" and len(store.events("s1")) == n_events
    assert [hashlib.sha256(p.read_bytes()).hexdigest() for p in files] == before
    assert (tmp_path / "out/demo_P01_s1/trials_wide.csv").read_bytes() == \
        (tmp_path / "out2/demo_P01_s1/trials_wide.csv").read_bytes(), "the CLI writes what the function writes"


def test_a_different_earlier_export_is_refused_without_force(db, tmp_path):
    store, ids = db
    out = tmp_path / "out"
    export(store.path, out, "s1")
    [again] = export(store.path, out, "s1")
    assert (again["written"], again["unchanged"]) == (0, 8), "the same data again: nothing to do"
    store.put_response(ids[2], "answer_deg", 25, "alice")  # the session moved on
    with pytest.raises(ExportError, match=r"demo_P01_s1 already holds a different export \(responses_long.csv, "
                                          r"session.json, trials_wide.csv\); pass --force"):
        export(store.path, out, "s1")
    assert read_csv(out / "demo_P01_s1/responses_long.csv")[1]["value"] == "20", "nothing was touched"
    result = cli("s1", "--out", out, "--data-dir", store.path.parent)
    assert result.returncode == 2 and "different export" in result.stderr and "--force" in result.stderr
    stray = out / "demo_P01_s1/trajectories/trial_9_attempt_1.csv"
    stray.write_text("tick\n")
    (out / "demo_P01_s1/notes.txt").write_text("mine")
    with pytest.raises(ExportError, match="trajectories/trial_9_attempt_1.csv"):
        export(store.path, out, "s1")
    [forced] = export(store.path, out, "s1", force=True)
    assert (forced["written"], forced["unchanged"], forced["removed"]) == (3, 5, 1)
    assert read_csv(out / "demo_P01_s1/responses_long.csv")[1]["value"] == "25" and not stray.exists()
    assert (out / "demo_P01_s1/notes.txt").read_text() == "mine", "files an export does not write stay"
    assert sorted(p.name for p in out.iterdir()) == ["demo_P01_s1"]


def test_all_sessions_and_the_cross_session_wide_file(db, tmp_path):
    store, ids = db
    out = tmp_path / "out"
    result = cli("--all", "--out", out, env={"VIESTAC_DATA": str(store.path.parent)})
    assert result.returncode == 0, result.stderr
    assert sorted(p.name for p in out.iterdir()) == ["all_trials_wide.csv", "demo_P01_s1", "demo_P02_s2"]
    rows = read_csv(out / "all_trials_wide.csv")
    assert [(r["session"], r["seq"]) for r in rows] == [("s1", "0"), ("s1", "1"), ("s1", "2"), ("s1", "3"),
                                                       ("s1", "4"), ("s2", "0")]
    assert "metric.errors" in rows[0] and rows[5]["metric.errors"] == "1" and rows[5]["response.answer_deg"] == "40"
    assert rows[1]["trajectory"] == "demo_P01_s1/trajectories/trial_1_attempt_2.csv"
    assert (out / rows[1]["trajectory"]).is_file()
    s2 = read_csv(out / "demo_P02_s2/trials_wide.csv")
    assert len(s2) == 1 and s2[0]["participant"] == "P02" and s2[0]["participant_index"] == "2"
    assert "metric.rt_s" not in s2[0], "a session's own file has its own union of columns"


def test_clear_errors(db, tmp_path):
    store, ids = db
    data = store.path.parent
    result = cli("nope", "--out", tmp_path / "out", "--data-dir", data)
    assert result.returncode == 2
    assert "unknown session 'nope'; known sessions: s1 (demo, participant P01, open); " \
           "s2 (demo, participant P02, completed)" in result.stderr
    result = cli("s1", "--out", tmp_path / "out", "--data-dir", tmp_path / "empty")
    assert result.returncode == 2 and f"no database at {tmp_path / 'empty' / 'viestac.sqlite'}" in result.stderr
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    result = cli("s1", "--out", blocker / "sub", "--data-dir", data)
    assert result.returncode == 2 and f"cannot write to {blocker / 'sub'}" in result.stderr
    result = cli("--out", tmp_path / "out", "--data-dir", data)
    assert result.returncode == 2 and "give a SESSION_ID or --all" in result.stderr
    assert not (tmp_path / "out").exists()
    with pytest.raises(ExportError, match="unknown session 's9'"):
        export(store.path, tmp_path / "out", "s9")
