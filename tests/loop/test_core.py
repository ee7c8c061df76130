"""Loop on a virtual clock: publish cadence, cue-change frames, tracker hold, device reports."""

import msgpack

from scenarios.contact_angle import ContactAngle
from server.core.records import TRAJECTORY_COLUMNS
from server.loop.tick import Loop
from server.loop.simulation import Simulation
from server.ipc.records import DeviceReport, Input, RecordEvery, ScenarioAnnounce, SwitchScenario, TrackerSample, Trial
from tests.ipc import sent, state_map

MS = 1_000_000


def step(core, now_ns):
    """Loop.step, with the state record as the map it goes on the socket as."""
    result, state = core.step(now_ns)
    return result, state_map(state)


def _dome(angle_inset=0.003):
    return [0.0, 0.0, 0.6 + 0.06 - angle_inset]


def make_core(state_hz=60.0):
    sim = Simulation(ContactAngle())
    return Loop(sim, state_hz=state_hz)


def test_cadence_is_exactly_state_hz_without_changes():
    core = make_core()
    published = [t for t in range(3000) if step(core, t * MS)[1] is not None]
    assert len(published) == 180  # 3 s at 60 Hz
    gaps = {b - a for a, b in zip(published, published[1:])}
    assert gaps <= {16, 17}


def test_cue_change_publishes_in_the_same_tick_as_the_device_command():
    core = make_core()
    for t in range(100):
        step(core, t * MS)
    core.apply(TrackerSample(1, 0, 0.0, _dome(), None, 100 * MS), 100 * MS)
    result, state = step(core, 100 * MS)
    assert result.cues_changed and state is not None, "the picture must leave with the cue"
    assert state["cues"] == [{"kind": "tilt", "direction_deg": 0.0, "magnitude_pct": 100.0}]
    assert state["trackers"] == [[1, 0, 0.0, 100 * MS, 100 * MS]]


def test_hip_holds_latest_sample_between_tracker_messages():
    core = make_core()
    core.apply(TrackerSample(1, 0, 0.0, [0.3, 0.2, 1.2], None, 0), 0)
    hips = {tuple(step(core, t * MS)[0].hip) for t in range(20)}
    assert hips == {(0.3, 0.2, 1.2)}


def test_samples_ride_with_state_records_and_are_msgpack_safe():
    core = make_core()
    state = None
    for t in range(40):
        _, rec = step(core, t * MS)
        core.record_sample(MS, 20_000)
        state = rec or state
    assert state is not None
    packed = msgpack.unpackb(msgpack.packb(["state", state], use_bin_type=True), raw=False)
    assert isinstance(packed[1]["samples"], bytes) and len(packed[1]["samples"]) % 24 == 0


def test_leaving_contact_stops_the_tilt_after_the_minimum_on_time():
    core = make_core()
    core.apply(TrackerSample(1, 0, 0.0, _dome(), None, 0), 0)
    cue_records = []
    for t in range(200):
        if t == 10:  # leave after 10 ms: the gate keeps contact for its 30 ms minimum on-time
            core.apply(TrackerSample(1, 1, 0.0, [0.0, 0.0, 1.2], None, t * MS), t * MS)
        _, state = step(core, t * MS)
        if state is not None and state["cues"] != (cue_records[-1][1] if cue_records else None):
            cue_records.append((t, state["cues"]))
    assert [cues for _, cues in cue_records] == [[{"kind": "tilt", "direction_deg": 0.0, "magnitude_pct": 100.0}], []]
    assert cue_records[0][0] == 0 and cue_records[1][0] == 30


def test_device_refusals_reach_the_scenario_and_its_hud():
    core = make_core()
    core.apply(DeviceReport({"refusals": ["tac (fingertac) cannot show the tilt cue"]}), 0)
    core.apply(TrackerSample(1, 0, 0.0, _dome(), None, 0), 0)
    _, state = step(core, 0)
    assert core.sim.data.refusals == ("tac (fingertac) cannot show the tilt cue",)
    assert "cannot show the tilt cue" in state["hud"]


def test_reusing_settled_steps_changes_nothing():
    """The held-HIP shortcut gives exactly what stepping the god-object every tick gives."""
    import math

    from server.core.haptics.god_object import GodObject

    sim = Simulation(ContactAngle())
    reference = GodObject(sim.scene.proxy_radius)
    reference_bodies = sim.scene.bodies()
    reused = 0
    for tick in range(3000):
        if tick % 8 == 0:  # a 120 Hz tracker sweeping the dome, slightly inside, and the crease
            a = math.radians(95 * math.sin(2 * math.pi * 0.5 * tick / 1000))
            r = 0.66 - 0.004
            sim.set_hip((0.0, r * math.sin(a), max(0.0, r * math.cos(a))))
        before = sim.tool._settled  # the fixed point is the tool's (server/core/tool.py)
        result = sim.step()
        reused += before is not None and before[0] == result.hip
        expected = reference.step(reference_bodies, result.hip)
        assert result.proxy == expected.proxy and result.contacts == expected.contacts, tick
    assert reused > 1500  # most ticks hold the previous sample


def test_mailbox_doorbell_counts_its_rings_across_processes():
    import subprocess
    import sys

    from server import ipc

    bell = ipc.Doorbell()
    assert bell.rings() == 0
    bell.ring()
    assert bell.rings() == 1 and bell.rings() == 0
    # Another process sees the same memory through the inherited fd (from its own start: 1 ring).
    code = ("import sys; from server import ipc; b = ipc.Doorbell(int(sys.argv[1])); "
            "print(b.rings()); b.ring(); b.ring()")
    out = subprocess.run([sys.executable, "-c", code, str(bell.fd)], pass_fds=(bell.fd,),
                         capture_output=True, text=True, check=True).stdout
    assert out.strip() == "1"
    assert bell.rings() == 2 and bell.rings() == 0
    bell.close()


def test_the_doorbell_count_survives_the_counter_wrapping():
    from server import ipc

    bell = ipc.Doorbell()
    bell._FMT.pack_into(bell._map, 0, 2**64 - 2)
    bell.rings()
    for _ in range(3):
        bell.ring()
    assert bell._FMT.unpack_from(bell._map, 0)[0] == 1 and bell.rings() == 3
    bell.close()


def test_scenario_switch_announces_the_new_scene_and_keeps_the_tick():
    core = make_core()
    for t in range(10):
        step(core, t * MS)
    core.apply(SwitchScenario("stiffness", {"middle_level": 3}, 5), 10 * MS)
    scene, scenario = core.outbox
    scene = sent(scene)
    assert scene[0] == "scene" and scene[1]["name"] == "stiffness" and scene[2] == core.sim.scene.hash
    assert scenario == ScenarioAnnounce({"id": "stiffness-v1", "params": {"middle_level": 3}, "seed": 5, "trial": None,
                                     "tick": 10})
    result, _ = step(core, 10 * MS)
    assert result.tick == 10, "the tick counter continues across scenarios"


def test_trial_record_reaches_the_scenario_and_is_announced():
    core = make_core()
    core.apply(Trial({"phase": "main", "params": {"angle_deg": -50}, "index": 1}), 0)
    assert core.outbox[-1].info["trial"] == {"phase": "main", "params": {"angle_deg": -50.0, "time_limit_s": 30.0},
                                           "index": 1}
    state = None
    for t in range(40):
        _, rec = step(core, t * MS)
        state = rec or state
    assert state["visible"] == {"angle_scale": False}, "main trials hide the angle scale"
    assert state["values"]["angle_deg"] == -50.0 and state["cues"][0]["direction_deg"] == 50.0


def test_events_ride_with_the_next_state_record_stamped_with_their_tick():
    core = make_core()
    core.apply(Input(1, "tap_angle", "press", 30.0), 0)
    _, first = step(core, 0)  # a publish is due in tick 0 anyway (first cadence slot)
    pressed, tap = first["events"]
    assert (pressed["name"], pressed["tick"], pressed["key"], pressed["value"], pressed["client"]) == \
        ("input", 0, "tap_angle", 30.0, 1), "every key and command is recorded with its tick and sender"
    assert (tap["name"], tap["tick"], tap["angle_deg"]) == ("tap", 0, 30.0)
    later = [rec for t in range(1, 40) if (rec := step(core, t * MS)[1]) is not None]
    assert all(rec["events"] == [] for rec in later), "each event is published once"


def test_trajectory_rows_ride_with_the_state_records_when_asked():
    core = make_core()
    rows = [row for t in range(30) if (rec := step(core, t * MS)[1]) is not None for row in rec["trajectory"]]
    assert rows == [], "nothing recorded unless an experiment asks"
    core.apply(RecordEvery(10), 30 * MS)
    recs = [r for t in range(30, 130) if (r := step(core, t * MS)[1]) is not None]
    rows = [row for rec in recs for row in rec["trajectory"]] + core.trajectory  # + what waits for the next record
    assert [row[0] for row in rows] == list(range(30, 130, 10)), "every 10th tick, none lost between records"
    assert len(rows[0]) == len(TRAJECTORY_COLUMNS) and rows[0][8] is None, "no carried object here"
    core.apply(RecordEvery(0), 130 * MS)
    assert all(r["trajectory"] == [] for t in range(130, 200) if (r := step(core, t * MS)[1]) is not None)


def test_device_cues_leave_once_per_change_across_scenario_switches_and_fail_safe():
    core = make_core()
    tilt = [{"kind": "tilt", "direction_deg": 0.0, "magnitude_pct": 100.0}]
    sent = []

    def tick(t):
        result, _ = step(core, t * MS)
        sent.append((t, core.device_cues(result)))

    tick(0)
    assert sent[-1] == (0, []), "after a (re)start the first tick tells the devices, even 'all off'"
    for t in range(1, 5):
        tick(t)
    assert all(cues is None for _, cues in sent[1:]), "nothing changed: nothing to send"
    core.apply(TrackerSample(1, 0, 0.0, _dome(), None, 5 * MS), 5 * MS)
    tick(5)
    tick(6)
    assert sent[-2:] == [(5, tilt), (6, None)]
    # A switch builds a new simulation whose first tick has no previous cues to differ from;
    # the devices still show the tilt, so "off" must go out.
    core.apply(SwitchScenario("stiffness", {}, 0), 7 * MS)
    tick(7)
    assert sent[-1] == (7, [])
    assert core.fail_safe_cues() is None, "already off: nothing to send"
    core.apply(SwitchScenario("contact-angle", {}, 0), 8 * MS)
    core.apply(TrackerSample(1, 1, 0.0, _dome(), None, 8 * MS), 8 * MS)
    tick(8)
    assert sent[-1] == (8, tilt)
    assert core.fail_safe_cues() == [] and core.fail_safe_cues() is None
    tick(9)
    assert sent[-1] == (9, tilt), "the next good tick sends its cues again"
    core.resend_device_cues()  # the cue channel was full: the same cues go again next tick
    tick(10)
    assert sent[-1] == (10, tilt)
