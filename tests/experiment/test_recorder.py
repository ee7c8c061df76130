"""The recorder on hand-made loop records: it records from the tick the loop announces the
trial, keeps cue changes only, takes the metrics from the state record's `finished` entries (the
trial's end as the scenario reported it), notices tracker loss."""

import pytest

from server.experiment.recorder import TRACKER_LOSS_TICKS, Recorder
from server.experiment.store import Store
from tests.experiment.cue_rows import cue_rows
from tests.experiment.test_store import clock, open_session
from server.ipc.records import ScenarioAnnounce, State


def state(tick, cues=(), events=(), trajectory=(), trackers=((1, 0, 0.0, 0, 0),), finished=()):
    return State.from_array(["state", {"tick": tick, "cues": list(cues), "events": list(events), "trajectory": list(trajectory),
                      "trackers": [list(t) for t in trackers], "finished": list(finished)}])


def row(tick):
    return [tick, 0.0, 0.1, 0.2, 0.0, 0.1, 0.2, 0, None, None, None, None]


@pytest.fixture
def recording(tmp_path):
    store = Store(tmp_path / "db.sqlite", clock())
    open_session(store)
    trial = store.transition(store.next_pending("s1").id, "running")
    recorder = Recorder(store)
    recorder.begin("s1", trial.id, trial.attempt, "main", 0)
    yield store, recorder, trial
    store.close()


def test_rows_count_from_the_tick_the_trial_took_effect(recording):
    store, recorder, trial = recording
    vib = {"kind": "vibration", "intensity_pct": 100.0}
    recorder.on_record(state(5, [vib], trajectory=[row(5)]))  # before any announcement: not this trial's
    recorder.on_record(ScenarioAnnounce({"trial": None, "tick": 8}))  # a scenario switch, not the trial
    recorder.on_record(ScenarioAnnounce({"trial": {"phase": "main", "params": {}, "index": 0}, "tick": 10}))
    recorder.on_record(state(17, [vib], trajectory=[row(9), row(10), row(15)]))
    recorder.on_record(state(34, [vib], events=[{"tick": 30, "name": "tap"}]))  # same cues: no new row
    recorder.on_record(state(51, [], events=[{"tick": 50, "name": "trial_done", "completion_s": 1.5, "t": 0.05}],
                             finished=[{"tick": 50, "metrics": {"completion_s": 1.5}}]))
    done = recorder.end()
    assert done.first_tick == 10 and done.metrics == {"completion_s": 1.5}
    assert [s["tick"] for s in store.samples(trial.id)] == [10, 15]
    assert [(c["tick"], c["cues"]) for c in cue_rows(store, trial.id)] == [(17, [vib]), (51, [])]
    names = [e["body"].get("name") for e in store.events("s1", trial.id) if e["kind"] == "scenario"]
    assert names == ["tap", "trial_done"]
    recorder.on_record(state(60, [vib]))  # after the end: nothing recorded
    assert len(cue_rows(store, trial.id)) == 2


def test_tracker_loss_and_return_are_events(recording):
    store, recorder, trial = recording
    recorder.on_record(ScenarioAnnounce({"trial": {"phase": "main", "params": {}, "index": 0}, "tick": 0}))
    recorder.on_record(state(100))
    recorder.on_record(state(100 + TRACKER_LOSS_TICKS, trackers=()))  # not yet: exactly the limit
    recorder.on_record(state(101 + TRACKER_LOSS_TICKS, trackers=()))
    recorder.on_record(state(130 + TRACKER_LOSS_TICKS, trackers=()))  # still lost: one event only
    recorder.on_record(state(500))
    recorder.end()
    tracker = [e["body"] for e in store.events("s1", trial.id) if e["kind"] == "tracker"]
    assert [b["name"] for b in tracker] == ["tracker_lost", "tracker_back"]
    assert tracker[0]["last_tick"] == 100 and tracker[1]["gap_ticks"] == 400
