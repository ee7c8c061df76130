"""The SQLite store: lifecycle transitions and their guards, responses, recorded streams, and
recovery of a trial a crash left running (a real `kill -9` of a writing process)."""

import itertools
import os
import signal
import subprocess
import sys
import textwrap

import pytest

from server.experiment.store import Conflict, Store, StoreError
from tests.experiment.cue_rows import cue_rows


def clock():
    ticks = itertools.count()
    return lambda: f"2026-11-21T08:00:{next(ticks) % 60:02d}.000000Z"


def plan(n=4):
    return [{"seq": i, "task": "angles", "kind": "main", "index": i, "scenario": "contact-angle-v1",
             "scenario_params": {"magnitude_pct": 100.0}, "device": "ferrovibe", "params": {"angle_deg": 10.0 * i},
             "condition": i, "repetition": 0, "duration_s": 30.0, "questions": ["answer_deg"]} for i in range(n)]


def open_session(store, sid="s1", participant="P01"):
    return store.create_session(session_id=sid, study_id="demo", study_title="Demo", study_hash="abc",
                                study_text="[study]", participant=participant, participant_index=0,
                                device="ferrovibe", experimenter="alice", notes="", software_version="0.1.0",
                                config={"tick_hz": 1000}, plan=plan())


@pytest.fixture
def store(tmp_path):
    s = Store(tmp_path / "data" / "viestac.sqlite", clock())
    yield s
    s.close()


def test_a_session_holds_its_plan_as_pending_trials(store):
    session = open_session(store)
    assert session["participant"] == "P01" and session["config"] == {"tick_hz": 1000}
    trials = store.trials("s1")
    assert [t.status for t in trials] == ["pending"] * 4 and trials[2].params == {"angle_deg": 20.0}
    assert store.db.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    with pytest.raises(Conflict, match="'P01' already has a session"):
        open_session(store, sid="s2")


def test_lifecycle_transitions_and_their_guards(store):
    open_session(store)
    t0 = store.next_pending("s1")
    running = store.transition(t0.id, "running", expect="pending", tick=100)
    assert running.attempt == 1 and running.started_tick == 100 and store.running().id == t0.id
    with pytest.raises(Conflict, match="is running, not pending"):
        store.transition(t0.id, "running", expect="pending")  # a second experimenter racing the first
    t1 = store.trials("s1")[1]
    with pytest.raises(Conflict, match="another trial is already running"):
        store.transition(t1.id, "running")
    assert store.trial(t1.id).status == "pending", "the refused start left nothing behind"
    with pytest.raises(StoreError, match="cannot become excluded"):
        store.transition(t0.id, "excluded")
    store.put_response(t0.id, "answer_deg", 10, "alice")
    store.put_response(t0.id, "answer_deg", 20, "alice")  # a correction: the last value counts
    done = store.transition(t0.id, "answered", tick=900, metrics={"rt_s": 0.8})
    assert done.status == "answered" and done.metrics == {"rt_s": 0.8} and store.responses(t0.id) == {"answer_deg": 20}
    assert store.transition(t0.id, "excluded", reason="outlier").reason == "outlier"
    store.transition(t1.id, "running")
    store.transition(t1.id, "aborted", reason="participant asked")
    again = store.transition(t1.id, "pending")
    assert again.status == "pending" and again.attempt == 1 and store.next_pending("s1").id == t1.id
    assert store.transition(t1.id, "running").attempt == 2
    kinds = [(e["body"]["from"], e["body"]["to"]) for e in store.events("s1") if e["kind"] == "lifecycle"]
    assert kinds == [("pending", "running"), ("running", "answered"), ("answered", "excluded"),
                     ("pending", "running"), ("running", "aborted"), ("aborted", "pending"), ("pending", "running")]


def test_recorded_streams_keep_their_attempt(store):
    open_session(store)
    t = store.next_pending("s1")
    store.transition(t.id, "running")
    row = (5, 0.0, 0.1, 0.2, 0.0, 0.1, 0.2, 1, "cube_a", 0.0, 0.1, -0.01)
    store.add_samples(t.id, 1, [row, row])  # a tick twice keeps one row
    store.add_cues(t.id, 1, [(5, [{"kind": "vibration", "intensity_pct": 100.0}])])
    store.add_events([("s1", t.id, 1, 5, "scenario", {"name": "tap"})])
    assert [s["tick"] for s in store.samples(t.id)] == [5] and store.samples(t.id)[0]["held"] == "cube_a"
    assert cue_rows(store, t.id)[0]["cues"][0]["kind"] == "vibration"
    assert store.events("s1", t.id)[-1]["body"] == {"name": "tap"}


WRITER = textwrap.dedent("""
    import itertools, sys, time
    from server.experiment.store import Store
    store = Store(sys.argv[1], lambda: "2026-11-21T08:00:00Z")
    trials = store.trials("s1")
    for t in trials[:3]:
        store.transition(t.id, "running")
        store.put_response(t.id, "answer_deg", t.seq, "alice")
        store.transition(t.id, "answered")
    store.transition(trials[3].id, "running")
    print("ready", flush=True)
    for tick in itertools.count():
        store.add_samples(trials[3].id, 1, [(tick, 0, 0, 0, 0, 0, 0, 0, None, None, None, None)])
""")


def test_kill_9_mid_trial_loses_only_the_running_trial(tmp_path):
    path = tmp_path / "viestac.sqlite"
    first = Store(path, clock())
    open_session(first)
    first.close()
    proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path)], stdout=subprocess.PIPE, text=True,
                            cwd=os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
    assert proc.stdout.readline().strip() == "ready"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    store = Store(path, clock())
    assert store.integrity() == "ok"
    trials = store.trials("s1")
    assert [t.status for t in trials] == ["answered"] * 3 + ["pending"], "the 4th goes back to the queue"
    assert [store.responses(t.id) for t in trials[:3]] == [{"answer_deg": i} for i in range(3)]
    assert store.next_pending("s1").seq == 3 and trials[3].attempt == 1 and trials[3].reason == "interrupted"
    assert [t.seq for t in store.interrupted] == [3]
    assert store.events("s1", trials[3].id)[-1]["kind"] == "interrupted"
    store.close()
