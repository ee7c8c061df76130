"""A loop restart during a recorded trial (docs/data.md "A loop restart during a trial"): the
recorder stops at the new loop's hello, the engine ends the attempt as interrupted with its rows,
the trial is pending again; a record of a tick before the trial is counted, never dropped
silently; export never shows a negative duration."""

from server.experiment.export import _duration
from server.experiment.recorder import Recorder
from tests.experiment.test_recorder import recording, row, state  # noqa: F401 - the fixture
from server.ipc.records import Hello, ScenarioAnnounce

MAIN = {"phase": "main", "params": {}, "index": 0}


def test_a_new_loops_hello_interrupts_the_recorded_trial_and_keeps_its_rows(recording):  # noqa: F811
    store, recorder, trial = recording
    recorder.on_record(Hello({"pid": 100}))  # the loop that runs the trial
    recorder.on_record(ScenarioAnnounce({"trial": MAIN, "tick": 10}))
    recorder.on_record(state(12, trajectory=[row(10), row(12)]))
    recorder.on_record(Hello({"pid": 101}))  # a restarted loop
    recorder.on_record(state(9000, trajectory=[row(9000)]))  # the new loop's: not this attempt's
    active = recorder.active
    assert active.interrupted == "loop restart" and active.last_tick == 12
    recorder.end()
    pending = store.interrupt(trial.id, active.interrupted, active.last_tick)
    assert (pending.status, pending.reason, pending.attempt) == ("pending", "interrupted", 1)
    assert [s["tick"] for s in store.samples(trial.id, 1)] == [10, 12], "the rows up to the crash are kept"
    last = store.events("s1", trial.id)[-1]
    assert (last["kind"], last["tick"], last["body"]) == ("interrupted", 12, {"reason": "loop restart"})
    again = store.transition(trial.id, "running", expect="pending")
    assert again.attempt == 2, "the retry is a new attempt"


def test_the_first_hello_interrupts_nothing(recording):  # noqa: F811
    _, recorder, _ = recording
    recorder.on_record(Hello({"pid": 100}))
    assert recorder.active.interrupted is None


def test_a_state_of_a_tick_before_the_trial_is_counted_and_said(recording):  # noqa: F811
    store, recorder, trial = recording
    recorder.on_record(ScenarioAnnounce({"trial": MAIN, "tick": 500}))
    recorder.on_record(state(510, trajectory=[row(505), row(510)]))
    recorder.on_record(state(3, trajectory=[row(1), row(3)]))  # ticks went back: must not vanish
    recorder.end()
    dropped = [e for e in store.events("s1", trial.id) if e["kind"] == "dropped"]
    assert len(dropped) == 1 and dropped[0]["body"]["state_records"] == 1 and dropped[0]["body"]["samples"] == 2


def test_export_durations_are_never_negative():
    went_back = {"started_tick": 5000, "ended_tick": 2657, "started_utc": "2026-01-01T10:00:00+00:00",
                 "ended_utc": "2026-01-01T10:00:07.5+00:00"}
    assert _duration(went_back, 1000.0) == (7.5, "utc"), "ticks that went back: the UTC stamps"
    clock_back = {**went_back, "ended_utc": "2026-01-01T09:59:00+00:00"}
    assert _duration(clock_back, 1000.0) == (None, "")
    assert _duration({"started_tick": 1000, "ended_tick": 3500}, 1000.0) == (2.5, "ticks")


def test_recorder_without_trial_ignores_hello(tmp_path):
    from server.experiment.store import Store
    from tests.experiment.test_store import clock
    recorder = Recorder(Store(tmp_path / "db.sqlite", clock()))
    recorder.on_record(Hello({"pid": 1}))
    recorder.on_record(Hello({"pid": 2}))
    assert recorder.active is None and recorder.loop_pid == 2
