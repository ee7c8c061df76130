"""Writes tests/vectors/ipc_records.json: the bytes of every record kind on every channel between
the server's processes (server/ipc), so that a change to how records are declared or built cannot
change what crosses a socket (tests/ipc/test_records.py).

The first version of the file was written by the code as it was before the records were typed
(positional lists built at each sender); running this again must give identical bytes. Records
that the loop builds (state, scene, scenario) come from a Loop run on a virtual clock.
"""

import json
from pathlib import Path

import msgpack

HERE = Path(__file__).parent
OUT = HERE / "ipc_records.json"


def _core_records() -> dict:
    """Records of a deterministic Loop run: the announcements and state records (drawn, not
    drawn, several tools with point rows, a failed tick's fault and recovery)."""
    from scenarios.contact_angle import ContactAngle
    from server.ipc.records import Input, RecordEvery, TrackerSample
    from server.loop.tick import Loop
    from server.loop.simulation import Simulation

    out = {}
    core = Loop(Simulation(ContactAngle(), seed=1), state_hz=60)
    scene, scenario = core.announce()
    out["loop_scene"], out["loop_scenario"] = scene, scenario
    now = 5_000_000_000
    core.apply(TrackerSample(3, 1, 10.0, [0.01, 0.12, 0.03], None, now), now)
    core.apply(RecordEvery(1), now)
    core.record_sample(1_000_100, 20_500, False)
    out["loop_state_drawn"] = core.tick((), now).state

    blind = Loop(Simulation(ContactAngle(), seed=1), state_hz=60, drawn=False)
    blind.apply(Input(2, "ArrowUp", "down"), now)
    blind.record_sample(999_000, 18_000, True)
    out["loop_state_not_drawn"] = blind.tick((), now).state

    fingers = Loop(Simulation(ContactAngle(), seed=1, rig=("right.thumb.tip",)), state_hz=60)
    fingers.apply(RecordEvery(1), now)
    fingers.apply(TrackerSample("udp:127.0.0.1:5000", 4, 11.0, [0.0, 0.1, 0.0], None, now, None,
                                {"right.thumb.tip": [0.02, 0.1, 0.0]}, 80.0), now)
    fingers.resyncs = 2  # as the loop process sets it
    out["loop_state_fingers"] = fingers.tick((), now).state
    return out


def typed_records() -> dict[str, dict]:
    """channel name → vector name → the record."""
    from server.core.cues import Tilt, cue_to_wire
    from server.ipc.records import (AudioCounters, AudioStatus, AudioStimuli, Alive, Answer, Calibrate, Capture, Cues, DeviceProfiles, DeviceReport,
                                    DeviceStatus, FailSafe, Fault, Hello, Input, Log, RecordEvery, Recovered,
                                    Snapshot, SnapshotRequest, SourcesHealth, Stop, SwitchScenario, TrackerGone, Trial)
    from server.wire import messages
    from server.loop.tracker_udp import parse_datagram

    cue = cue_to_wire(Tilt(direction_deg=90.0, magnitude_pct=100.0))
    hub_to_loop = {
        "tracker": messages.Tracker(7, 123.5, (0.01, 0.02, 0.03)).loop_record(3, 1_000_000_123),
        "tracker_quat": messages.Tracker(8, 124.5, (0.01, 0.02, 0.03), (1.0, 0.0, 0.0, 0.0)).loop_record(3, 1_000_000_999),
        "tracker_points": messages.Tracker(9, 125.0, (0.0, 0.1, 0.0), None, "right.index.tip",
                                           {"right.thumb.tip": (0.02, 0.1, 0.0)}, 50.0).loop_record(4, 2_000_000_000),
        "tracker_udp": parse_datagram(msgpack.packb({"type": "tracker", "seq": 1, "t": 2.5, "pos": [0.1, 0.2, 0.3],
                                                     "ttl": 40}), "udp:127.0.0.1:40000", 3_000_000_000),
        "input": Input(4, "ArrowUp", "down"),
        "input_value": Input(0, "tap_angle", "press", 30),
        "trial": Trial({"phase": "main", "params": {"angle_deg": -50.0}, "index": 2}),
        "trial_end": Trial(None),
        "scenario": SwitchScenario("stiffness-v1", {"pairs": 3}, 7, 2),  # numbered switches (issue 33): one element more
        "devices": DeviceReport({"refusals": ["no tilt device"], "status": {"tilt": "connected"}}),
        "record": RecordEvery(4),
        "tracker_gone": TrackerGone(5),
        "stop": Stop(),
    }
    loop_to_hub = {
        "hello": Hello({"pid": 1234, "rt": False, "tick_hz": 1000, "state_hz": 60.0, "scenario": "contact-angle",
                        "cpu": None}),
        "fault": Fault(1, 10, "ZeroDivisionError: division by zero"),
        "recovered": Recovered(11, 1),
        "fail_safe": FailSafe(),
        "log": Log("warning", "tracker samples from 1 ignored"),
        **_core_records(),
    }
    cue_channel = {
        "cues": Cues(12, 999_000, [cue]),
        "cues_off": Cues(13, 1_000_000, []),
        "cues_fingers": Cues(14, 1_001_000, [cue], {"right.thumb.tip": [], "right.index.tip": [cue]}),
        "alive": Alive(15, 1_002_000),
    }
    device_control = {
        "snapshot_request": SnapshotRequest(1, 0),
        "stop": Stop(),
        "hello": Hello({"pid": 4321}),
        "report": DeviceStatus({"refusals": [], "status": {"tilt": "connected"}}),
        "profiles": DeviceProfiles({"tilt": {"model": "tilt-v1", "shows": ["tilt"]}}),
        "snapshot": Snapshot(1, {"devices": {}, "feed": {"records": 0}}),
    }
    tracker_control = {
        "calibrate": Calibrate(2, "leap", {"units": "mm", "scale": 0.001}),
        "calibrate_default": Calibrate(3, "leap", None),
        "capture": Capture(4, "leap", 1.5),
        "stop": Stop(),
        "hello": Hello({"pid": 999, "rt": True}),
        "health": SourcesHealth([{"name": "leap", "kind": "leap", "status": "ok", "reasons": []}]),
        "answer": Answer(2, {"ok": True, "calibration": {"units": "mm"}}),
    }
    channels = {"hub_to_loop": hub_to_loop, "loop_to_hub": loop_to_hub, "cue_channel": cue_channel,
                "hub_to_device_host": {k: device_control[k] for k in ("snapshot_request", "stop")},
                "device_host_to_hub": {k: device_control[k] for k in ("hello", "report", "profiles", "snapshot")},
                "hub_to_tracker_host": {k: tracker_control[k] for k in ("calibrate", "calibrate_default", "capture",
                                                                         "stop")},
                "tracker_host_to_hub": {k: tracker_control[k] for k in ("hello", "health", "answer")},
                "device_host_to_audio_worker": {
                    "stimuli": AudioStimuli(7, [{"shape": "sine", "amplitude": 0.5, "frequency_hz": 250.0, "on_s": 0.0,
                                                 "off_s": 0.0, "duty": 0.5, "to_amplitude": None,
                                                 "to_frequency_hz": None, "sweep_s": 0.0, "start": 96000,
                                                 "duration": 4800}]),
                    "stop": Stop()},
                "audio_worker_to_device_host": {
                    "status": AudioStatus("connected", "streaming to system at 48000 Hz, 64-frame blocks"),
                    "counters": AudioCounters(750, 2, 48000, [[7, 47936]])}}
    return channels


def records() -> dict[str, dict]:
    """channel name → vector name → the record's bytes (hex), and the /ws state messages."""
    typed = typed_records()
    vectors = {channel: {name: msgpack.packb(record.to_array(), use_bin_type=True).hex()
                         for name, record in named.items()} for channel, named in typed.items()}
    vectors["ws_state"] = _ws_states(typed["loop_to_hub"])
    return vectors


TELEMETRY = {"period_p50_us": 1000.0, "period_p99_us": 1010.5, "period_max_us": 1200.0, "overruns": 0,
             "tick_cost_p99_us": 30.0, "ticks": 5000, "rt": False}


def _ws_states(loop_to_hub: dict) -> dict[str, str]:
    """The /ws `state` message the hub makes of each drawn state record, in both formats (hex of
    the bytes; JSON as UTF-8)."""
    from server.wire import codec, messages

    out = {}
    for name in ("loop_state_drawn", "loop_state_fingers"):
        message = messages.state_message(loop_to_hub[name].view, TELEMETRY)
        for fmt in codec.FORMATS:
            data = codec.encode(message, fmt)
            out[f"{name}.{fmt}"] = (data.encode() if isinstance(data, str) else data).hex()
    return out


def main() -> None:
    OUT.write_text(json.dumps({"version": 1, "note": "server/ipc records; written by "
                                                     "tests/vectors/make_ipc_vectors.py",
                               "channels": records()}, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
