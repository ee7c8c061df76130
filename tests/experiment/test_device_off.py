"""A trial recorded while a device its scenario needs was off is flagged, from the recorder's own
events: a `device_off` event (at the start, or when the device goes during the trial) and a
`device_back` event; the session view lists the devices (`device_off`) and the export has a
`device_off` column (docs/data.md "Trials recorded with a device off")."""

import csv

import pytest

from server.experiment.export import export
from server.experiment.recorder import Recorder
from server.experiment.store import Store
from server.ipc.records import DeviceReport, ScenarioAnnounce
from tests.experiment.test_recorder import state
from tests.experiment.test_store import clock, open_session

NEEDS = {"macro_roughness": ("ferrovibe",)}  # contact-angle on the simulated rig (devices/capability.py showing)


def report(**statuses):
    return DeviceReport({"refusals": [], "status": statuses})


@pytest.fixture
def store(tmp_path):
    store = Store(tmp_path / "data" / "viestac.sqlite", clock())
    open_session(store)
    yield store
    store.close()


def run(store, recorder, before=(), during=()):
    trial = store.transition(store.next_pending("s1").id, "running")
    for r in before:
        recorder.on_record(r)
    recorder.begin("s1", trial.id, trial.attempt, "main", 0, needs=NEEDS)
    recorder.on_record(ScenarioAnnounce({"trial": {"phase": "main", "params": {}, "index": 0}, "tick": 10}))
    recorder.on_record(state(20))
    for r in during:
        recorder.on_record(r)
    recorder.on_record(state(40))
    recorder.end()
    store.transition(trial.id, "answered", expect="running")
    return trial


def kinds(store, trial):
    return [(e["kind"], e["body"].get("devices"), e["body"].get("at")) for e in store.events("s1", trial.id)
            if e["kind"] in ("device_off", "device_back")]


def test_a_device_that_goes_during_the_trial_flags_it(store):
    recorder = Recorder(store)
    trial = run(store, recorder, before=[report(ferrovibe="connected", fingertac="connected")],
                during=[report(ferrovibe="disconnected", fingertac="connected"), report(ferrovibe="handshaking"),
                        report(ferrovibe="connected")])
    assert kinds(store, trial) == [("device_off", ["ferrovibe"], "during"), ("device_back", None, None)]
    assert store.devices_off("s1") == {(trial.id, 1): ["ferrovibe"]}


def test_a_device_off_at_the_start_flags_it_and_one_not_needed_does_not(store):
    recorder = Recorder(store)
    off = run(store, recorder, before=[report(ferrovibe="disconnected", fingertac="connected")])
    assert kinds(store, off) == [("device_off", ["ferrovibe"], "start")]
    fine = run(store, recorder, before=[report(ferrovibe="connected")], during=[report(fingertac="disconnected")])
    assert kinds(store, fine) == [], "fingertac shows nothing contact-angle needs"
    assert store.devices_off("s1") == {(off.id, 1): ["ferrovibe"]}


def test_the_export_has_a_device_off_column(store, tmp_path):
    recorder = Recorder(store)
    off = run(store, recorder, before=[report(ferrovibe="connected")], during=[report(ferrovibe="disconnected")])
    run(store, recorder, before=[report(ferrovibe="connected")])
    [summary] = export(store.path, tmp_path / "out", "s1")
    with open(f"{summary['dir']}/trials_wide.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    flags = {r["seq"]: r["device_off"] for r in rows}
    assert flags[str(off.seq)] == "ferrovibe"
    assert [v for s, v in flags.items() if s != str(off.seq)] == [""] * (len(rows) - 1)
