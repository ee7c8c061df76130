"""LoopCore on a virtual clock: publish cadence, cue-change frames, tracker hold, sinks."""

import msgpack

from devices.simulated import SimulatedFerroVibe
from scenarios.contact_angle import ContactAngle
from server.loop.core import LoopCore
from server.loop.simulation import Simulation

MS = 1_000_000


def _dome(angle_inset=0.003):
    return [0.0, 0.0, 0.6 + 0.06 - angle_inset]


def make_core(state_hz=60.0):
    sim = Simulation(ContactAngle())
    return LoopCore(sim, [SimulatedFerroVibe()], state_hz=state_hz)


def test_cadence_is_exactly_state_hz_without_changes():
    core = make_core()
    published = [t for t in range(3000) if core.step(t * MS)[1] is not None]
    assert len(published) == 180  # 3 s at 60 Hz
    gaps = {b - a for a, b in zip(published, published[1:])}
    assert gaps <= {16, 17}


def test_cue_change_publishes_in_the_same_tick_as_the_device_command():
    core = make_core()
    for t in range(100):
        core.step(t * MS)
    core.apply(["tracker", 1, 0, 0.0, _dome(), None, 100 * MS], 100 * MS)
    result, state = core.step(100 * MS)
    assert result.cues_changed and state is not None, "the picture must leave with the cue"
    assert state["cues"] == [{"kind": "tilt", "direction_deg": 0.0, "magnitude_pct": 100.0}]
    assert state["devices"] and state["devices"][0]["command"] == "tilt"
    assert state["devices"][0]["t"] == result.t_s
    assert state["trackers"] == [[1, 0, 0.0, 100 * MS, 100 * MS]]


def test_hip_holds_latest_sample_between_tracker_messages():
    core = make_core()
    core.apply(["tracker", 1, 0, 0.0, [0.3, 0.2, 1.2], None, 0], 0)
    hips = {tuple(core.step(t * MS)[0].hip) for t in range(20)}
    assert hips == {(0.3, 0.2, 1.2)}


def test_samples_ride_with_state_records_and_are_msgpack_safe():
    core = make_core()
    state = None
    for t in range(40):
        _, rec = core.step(t * MS)
        core.record_sample(MS, 20_000)
        state = rec or state
    assert state is not None
    packed = msgpack.unpackb(msgpack.packb(["state", state], use_bin_type=True), raw=False)
    assert isinstance(packed[1]["samples"], bytes) and len(packed[1]["samples"]) % 16 == 0


def test_leaving_contact_stops_the_tilt_after_the_dwell():
    core = make_core()
    core.apply(["tracker", 1, 0, 0.0, _dome(), None, 0], 0)
    for t in range(50):
        core.step(t * MS)
    core.apply(["tracker", 1, 1, 0.0, [0.0, 0.0, 1.2], None, 50 * MS], 50 * MS)
    commands = []
    for t in range(50, 200):
        core.step(t * MS)
        commands.extend(core.device_events)
        core.device_events = []
    sink = core.sinks[0]
    assert [c["command"] for c in sink.commands] == ["tilt", "flat"]
