"""Several tools (one per tracked point) in the simulation and the loop's core: protocol v1.4's
tracker `point`/`points`/`ttl`, the state's `tools`/`points`/`tracking`, tracker loss, and each
device getting the cues of its own finger."""

from dataclasses import replace

import msgpack
import pytest

from devices.feed import DeviceFeed
from devices.manager import DeviceConfig, DeviceManager
from devices.ports import PortSpec
from devices.profiles import profile_by_model
from scenarios.contact_angle import ContactAngle
from server.core.cues import Tilt, Vibration
from server.core.points import PRIMARY_POINT
from server.core.tool import DEFAULT_PROXY_RADIUS
from server.loop.tick import Loop
from server.loop.simulation import Simulation, home_position, tool_names
from server.wire import messages
from server.loop.tracker_udp import parse_datagram
from server.ipc.records import CUES, Cues, Input, RecordEvery, SwitchScenario, TrackerGone, TrackerSample, Trial
from tests.ipc import sent, state_map

MS = 1_000_000
THUMB = "right.thumb.tip"
DOME_TOP = (0.0, 0.0, 0.6 + DEFAULT_PROXY_RADIUS - 0.003)  # 3 mm into the dilated dome: contact, tilt 0
FREE = (0.0, 0.0, 1.2)
FREE_SIDE = (0.0, 0.4, 1.2)


def tracker(source, seq, pos, point=None, points=None, ttl=None) -> list:
    """The loop's tracker record, as the hub and the UDP port build it (Tracker.loop_record)."""
    return messages.Tracker(seq, 0.0, tuple(pos), None, point, points, ttl).loop_record(source, 0)


def two_fingers(scenario=None, **kw) -> Loop:
    return Loop(Simulation(scenario or ContactAngle(), rig=(THUMB,)), state_hz=1000, **kw)


def run(core: Loop, ticks: int, records=()):
    """`ticks` ticks, `records` applied before the first; every tick's (tick, state, cues) kept."""
    out = []
    for i in range(ticks):
        o = core.tick(list(records) if i == 0 else [], core.sim.data.tick * MS)
        out.append((o.tick, state_map(o.state), o.cues, o.finger_cues, o.result))
    return out


# -- tools and their names ----------------------------------------------------------------------

def test_the_default_rig_has_one_tool_the_primary_point_and_the_state_lists_it():
    core = Loop(Simulation(ContactAngle()))
    state = state_map(core.tick([tracker(1, 0, DOME_TOP)], 0).state)
    assert [t.name for t in core.sim.data.tools] == [PRIMARY_POINT]
    assert state["tools"] == [{"name": PRIMARY_POINT, "hip": state["hip"], "proxy": state["proxy"], "contact": True,
                               "lost": False}]
    assert state["points"] == {} and state["tracking"] == {"lost": []}


def test_tools_are_the_primary_then_the_rig_then_what_the_scenario_needs_each_once():
    class Grasp(ContactAngle):
        fingers = (PRIMARY_POINT, "right.middle.tip", THUMB)
    sim = Simulation(Grasp(), rig=(THUMB, "left.index.tip"))
    assert [t.name for t in sim.data.tools] == [PRIMARY_POINT, THUMB, "left.index.tip", "right.middle.tip"]
    assert len({id(t.gate) for t in sim.data.tools}) == 4, "each tool has its own contact gate"
    with pytest.raises(ValueError, match="not a tracked point name"):
        tool_names(("right.index.nail",))


def test_a_sample_naming_a_point_moves_that_tool_only_and_each_tool_touches_on_its_own():
    core = two_fingers()
    (_, state, cues, fingers, result), = run(core, 1, [tracker(1, 0, FREE), tracker(1, 1, DOME_TOP, point=THUMB)])
    index, thumb = result.tools
    assert (index.name, index.hip, index.contact) == (PRIMARY_POINT, FREE, False)
    assert (thumb.name, thumb.hip, thumb.contact, thumb.touching) == (THUMB, DOME_TOP, True, frozenset({"hemisphere"}))
    assert thumb.force[2] > 0 and index.force == (0.0, 0.0, 0.0)
    assert [t["contact"] for t in state["tools"]] == [False, True]
    # contact-angle cues the primary tool's devices only: the thumb's touch cues nobody
    assert cues == [] and fingers == {THUMB: []}


def test_the_scenario_sees_every_tool_primary_first():
    seen = []

    class Watching(ContactAngle):
        def step(self, ctx):
            seen.append(ctx.tools)
            return super().step(ctx)
    core = Loop(Simulation(Watching(), rig=(THUMB,)))
    core.tick([tracker(1, 0, DOME_TOP), tracker(1, 1, FREE_SIDE, point=THUMB)], 0)
    (index, thumb), = seen
    assert index.name == PRIMARY_POINT and index.contact and index.hip == DOME_TOP
    assert thumb.name == THUMB and not thumb.contact and thumb.hip == FREE_SIDE and not thumb.lost


def test_points_of_a_sample_move_their_tools_and_the_others_are_drawn():
    core = two_fingers()
    points = {THUMB: DOME_TOP, "right.wrist": (0.1, 0.2, 1.5), "right.palm": (0.1, 0.1, 1.4)}
    (_, state, _, _, result), = run(core, 1, [tracker(1, 0, FREE, points=points)])
    assert [t.hip for t in result.tools] == [FREE, DOME_TOP]
    assert state["points"] == {"right.wrist": [0.1, 0.2, 1.5], "right.palm": [0.1, 0.1, 1.4]}
    assert state["driver"] == [1, 0] and core.sim.data.tool_by_name[THUMB].driver == 1


def test_the_tracker_rule_holds_per_tool():
    core = two_fingers()
    core.tick([tracker(1, 0, FREE), tracker(2, 0, FREE_SIDE, point=THUMB)], 0)
    out = core.tick([tracker(2, 1, DOME_TOP), tracker(1, 1, DOME_TOP, point=THUMB)], MS)
    assert [t.hip for t in out.result.tools] == [FREE, FREE_SIDE], "each tool keeps its own driver"
    assert [t.driver for t in core.sim.data.tools] == [1, 2]
    assert "from 1 ignored: 2 drives right.thumb.tip" in " ".join(r[2] for r in map(sent, out.records) if r[0] == "log")


# -- tracker loss (ttl) -------------------------------------------------------------------------

def test_a_source_whose_ttl_passes_is_lost_its_tools_leave_contact_and_the_devices_go_off():
    core = two_fingers()
    record = tracker("udp:127.0.0.1:9", 7, DOME_TOP, points={THUMB: DOME_TOP}, ttl=60)
    ticks = run(core, 100, [record])
    assert ticks[0][2] == [{"kind": "tilt", "direction_deg": 0.0, "magnitude_pct": 100.0}]
    lost_at = next(tick for tick, state, *_ in ticks if any(e["name"] == "tracker_lost" for e in state["events"]))
    assert lost_at == 60, "lost in the first tick at or after the sample's ttl (60 ms after it was applied)"
    tick, state, cues, fingers, result = ticks[lost_at]
    assert cues == [] and fingers == {THUMB: []}, "the lost tick turns the devices off"
    assert not result.contact and all(not t.contact and t.lost for t in result.tools)
    assert state["events"] == [{"tick": 60, "t": 0.06, "name": "tracker_lost", "source": "udp:127.0.0.1:9",
                                "tools": [PRIMARY_POINT, THUMB]}]
    home = list(home_position(core.sim.scene))
    assert [(t["hip"], t["lost"]) for t in state["tools"]] == [(home, True), (home, True)]
    assert state["tracking"] == {"lost": ["udp:127.0.0.1:9"]} and state["driver"] is None
    assert all(not r.contact for *_, r in ticks[lost_at:])


def test_loss_does_not_wait_for_the_gates_minimum_on_time():
    """The gate holds contact on for min_on_s (30 ms) after switching on; a lost finger must not."""
    core = Loop(Simulation(ContactAngle()), state_hz=1000)
    ticks = run(core, 10, [tracker("udp:a", 1, DOME_TOP, ttl=2)])
    assert [r.contact for *_, r in ticks[:4]] == [True, True, False, False]
    assert ticks[2][2] == []


def test_a_lost_source_that_sends_again_is_back():
    core = Loop(Simulation(ContactAngle()), state_hz=1000)
    run(core, 30, [tracker("udp:a", 1, DOME_TOP, ttl=20)])
    assert core.sim.data.lost_sources == {"udp:a": (PRIMARY_POINT,)}
    (tick, state, cues, _, result), = run(core, 1, [tracker("udp:a", 2, DOME_TOP, ttl=20)])
    assert [e["name"] for e in state["events"]] == ["tracker_back"]
    assert state["events"][0]["source"] == "udp:a" and state["tracking"] == {"lost": []}
    assert result.contact and not result.tools[0].lost and cues == [
        {"kind": "tilt", "direction_deg": 0.0, "magnitude_pct": 100.0}]


def test_another_source_taking_over_the_lost_tools_clears_the_loss():
    core = Loop(Simulation(ContactAngle()), state_hz=1000)
    run(core, 30, [tracker("udp:a", 1, DOME_TOP, ttl=20)])
    (_, state, *_), = run(core, 1, [tracker(5, 1, FREE)])
    assert state["tracking"] == {"lost": []} and state["driver"] == [5, 1] and not state["tools"][0]["lost"]


def test_a_sample_without_ttl_is_held_as_the_mouse_is():
    core = Loop(Simulation(ContactAngle()), state_hz=1000)
    ticks = run(core, 2000, [tracker(3, 1, DOME_TOP)])
    assert all(r.contact for *_, r in ticks) and core.sim.data.lost_sources == {}


def test_a_lost_source_drops_its_drawn_points_and_a_source_that_leaves_is_not_lost():
    core = Loop(Simulation(ContactAngle()), state_hz=1000)
    ticks = run(core, 50, [tracker("udp:a", 1, FREE, points={"right.wrist": (0, 0, 1.4)}, ttl=40)])
    assert ticks[0][1]["points"] == {"right.wrist": [0.0, 0.0, 1.4]} and ticks[-1][1]["points"] == {}
    core = Loop(Simulation(ContactAngle()), state_hz=1000)
    run(core, 5, [tracker(4, 1, DOME_TOP, points={"right.wrist": (0, 0, 1.4)}, ttl=40)])
    (_, state, *_), = run(core, 1, [TrackerGone(4)])
    assert state["points"] == {} and state["tracking"] == {"lost": []} and not state["contact"]
    assert run(core, 60)[-1][1]["events"] == [], "no loss is reported for a source that left"


def test_a_scenario_switch_keeps_who_drives_each_tool_and_what_is_lost():
    core = two_fingers()
    run(core, 30, [tracker("udp:a", 1, FREE, point=THUMB, ttl=5), tracker(2, 1, DOME_TOP)])
    core.tick([SwitchScenario("contact-angle", {}, 0)], 0)
    assert [t.driver for t in core.sim.data.tools] == [2, None] and core.sim.data.tool_by_name[THUMB].lost
    assert core.sim.data.lost_sources == {"udp:a": (THUMB,)}


def test_a_scenario_switch_keeps_the_drawn_points_and_the_ttl_running_and_starts_the_objects_anew():
    """What SimData.carry_over carries: a source's drawn points and its ttl (it is lost after the
    switch as it would have been before); what the new scenario starts without: the old objects."""
    core = two_fingers()
    run(core, 5, [tracker("udp:h", 1, DOME_TOP, points={"right.wrist": (0, 0, 1.4)}, ttl=40)])
    core.tick([Input(1, "scale", "press", False)], 0)
    assert core.sim.data.visibility == {"angle_scale": False} and core.sim.data.deadlines == {"udp:h": 0.04}
    ticks = run(core, 50, [SwitchScenario("contact-angle", {}, 0)])
    assert ticks[0][1]["points"] == {"right.wrist": [0.0, 0.0, 1.4]}
    assert ticks[0][1]["visible"] == {"angle_scale": True}, "the new scenario's own, not the old one's hidden scale"
    lost = [(tick, e["source"]) for tick, state, *_ in ticks for e in state["events"] if e["name"] == "tracker_lost"]
    assert lost == [(40, "udp:h")] and ticks[-1][1]["points"] == {}


# -- each device gets its own finger's cues ------------------------------------------------------

class Fingers(ContactAngle):
    """Contact angle that also buzzes the thumb's devices while the thumb touches."""

    def step(self, ctx):
        out = super().step(ctx)
        thumb = next(t for t in ctx.tools if t.name == THUMB)
        if not thumb.contact:
            return out
        return replace(out, tool_cues={THUMB: (Vibration(50.0, 235.0),)})


class Recorder:
    """Stands in for a device's SerialDevice: keeps the commands it is given."""

    def __init__(self):
        self.given = []

    def set_commands(self, commands, write_now=False):
        self.given.append(list(commands))

    def snapshot(self, writes=0):
        return {"name": self.name}


def rig_of_two():
    configs = [DeviceConfig("ferrovibe", profile_by_model("ferrovibe"), PortSpec.parse("/dev/null"),
                            finger=PRIMARY_POINT),
               DeviceConfig("fingertac", profile_by_model("fingertac"), PortSpec.parse("/dev/null"), finger=THUMB)]
    manager = DeviceManager(configs)
    drivers = {}
    for name, d in manager.devices.items():
        d.driver = drivers[name] = Recorder()
        d.driver.name = name
    return manager, drivers


def feed_ticks(core, feed, records_by_tick, ticks):
    for i in range(ticks):
        out = core.tick(records_by_tick.get(i, []), i * MS)
        if out.cues is not None:
            feed.handle(Cues(out.tick, i * MS, out.cues, out.finger_cues), i * MS)


def given(manager, drivers, name, cues) -> bool:
    """The device `name` was last given exactly what its encoder makes of `cues`."""
    return drivers[name].given[-1] == list(manager.devices[name].encoder.encode(cues).commands.values())


def test_the_device_snapshot_says_each_device_s_finger():
    manager, _ = rig_of_two()
    assert {d["name"]: d["finger"] for d in manager.snapshot()["devices"]} == {"ferrovibe": PRIMARY_POINT,
                                                                               "fingertac": THUMB}


def test_touching_with_the_index_cues_only_the_index_device():
    core = two_fingers()
    manager, drivers = rig_of_two()
    feed = DeviceFeed(manager)
    feed_ticks(core, feed, {0: [tracker(1, 0, DOME_TOP), tracker(1, 1, FREE_SIDE, point=THUMB)]}, 5)
    assert manager.cues == (Tilt(0.0, 100.0),) and manager.finger_cues == {THUMB: ()}
    assert given(manager, drivers, "ferrovibe", (Tilt(0.0, 100.0),))
    assert given(manager, drivers, "fingertac", ()), "the thumb's device stays off"
    assert not given(manager, drivers, "ferrovibe", ()), "(the tilt is not what off looks like)"


def test_touching_with_the_thumb_cues_only_the_thumb_device():
    core = two_fingers(Fingers())
    manager, drivers = rig_of_two()
    feed = DeviceFeed(manager)
    feed_ticks(core, feed, {0: [tracker(1, 0, FREE), tracker(1, 1, DOME_TOP, point=THUMB)]}, 5)
    assert manager.cues == () and manager.finger_cues == {THUMB: (Vibration(50.0, 235.0),)}
    assert given(manager, drivers, "fingertac", (Vibration(50.0, 235.0),))
    assert not given(manager, drivers, "fingertac", ())
    assert given(manager, drivers, "ferrovibe", ()), "the index's device stays off"


def test_a_fail_safe_turns_every_finger_off():
    manager, drivers = rig_of_two()
    feed = DeviceFeed(manager)
    feed.handle(Cues(1, 0, [], {THUMB: [{"kind": "vibration", "intensity_pct": 50.0, "carrier_hz": 235.0}]}), 0)
    assert manager.finger_cues == {THUMB: (Vibration(50.0, 235.0),)}
    feed.handle(Cues(2, 0, []), 0)  # a fail-safe record names no finger: all off
    assert manager.cues == () and manager.finger_cues == {}
    with pytest.raises(ValueError, match="not a cue record"):
        feed.handle(CUES.decode(["cues", 3, 0, [], {THUMB: "buzz"}]), 0)


# -- the wire -----------------------------------------------------------------------------------

def test_v14_tracker_fields_reach_the_loop_record_through_the_udp_port():
    datagram = msgpack.packb({"type": "tracker", "seq": 4, "t": 1.5, "pos": [0, 0, 1], "point": THUMB,
                              "points": {"right.palm": [0, 0.1, 1]}, "ttl": 40})
    assert parse_datagram(datagram, "udp:x", 9) == TrackerSample("udp:x", 4, 1.5, [0.0, 0.0, 1.0], None, 9, THUMB, {"right.palm": [0.0, 0.1, 1.0]}, 40.0)
    plain = msgpack.packb({"type": "tracker", "seq": 4, "t": 1.5, "pos": [0, 0, 1]})
    assert parse_datagram(plain, "udp:x", 9) == TrackerSample("udp:x", 4, 1.5, [0.0, 0.0, 1.0], None, 9)


# -- recording every tool's tracked point -------------------------------------------------------

def test_no_point_rows_with_one_tool_and_no_hand():
    core = Loop(Simulation(ContactAngle()), state_hz=1000)
    core.apply(RecordEvery(1), 0)
    state = state_map(core.tick([tracker(1, 0, DOME_TOP)], 0).state)
    assert len(state["trajectory"]) == 1 and "point_rows" not in state


def test_the_recorder_keeps_every_tracked_point_and_the_loss_and_export_writes_a_multipoint_csv(tmp_path):
    import csv

    from server.experiment.export import export
    from server.experiment.recorder import Recorder
    from tests.experiment.test_export import PLAN, clock, new_session

    from server.experiment.store import Store
    store = Store(tmp_path / "db.sqlite", clock())
    ids = new_session(store, "s1", "P01", PLAN)
    trial = store.transition(ids[1], "running")
    recorder = Recorder(store)
    recorder.begin("s1", trial.id, trial.attempt, "main", 0)
    core = two_fingers()
    core.apply(RecordEvery(10), 0)
    out = core.tick([Trial({"phase": "main", "params": {"angle_deg": 10.0}, "index": 0}),
                     tracker("udp:h", 1, DOME_TOP, points={THUMB: FREE_SIDE, "right.wrist": (0, 0, 1.5)}, ttl=30)], 0)
    for _ in range(60):
        for record in out.records:
            recorder.on_record(record)
        if out.state is not None:
            recorder.on_record(out.state)
        out = core.tick((), core.sim.data.tick * MS)
    recorder.end()
    rows = store.point_samples(trial.id, trial.attempt)
    assert [tick for tick, _ in rows] == list(range(0, 60, 10))
    dome_top = [round(v, 9) for v in DOME_TOP]  # recorded to 9 decimals, as the state's positions
    assert rows[0][1] == {PRIMARY_POINT: dome_top, THUMB: list(FREE_SIDE), "right.wrist": [0, 0, 1.5]}
    home = [round(v, 9) for v in home_position(core.sim.scene)]
    assert rows[-1][1] == {PRIMARY_POINT: home, THUMB: home}, "lost: the tools home, the wrist gone"
    lost = [e for e in store.events("s1", trial.id) if e["body"].get("name") == "tracker_lost"]
    assert [(e["kind"], e["tick"], e["body"]["source"], e["body"]["tools"]) for e in lost] == [
        ("tracker", 30, "udp:h", [PRIMARY_POINT, THUMB])]

    export(store.path, tmp_path / "out", "s1")
    path = tmp_path / "out" / "demo_P01_s1" / "trajectories" / f"trial_1_attempt_{trial.attempt}_points.csv"
    with path.open() as f:
        table = list(csv.reader(f))
    assert table[0] == ["t", "right.wrist.x", "right.wrist.y", "right.wrist.z", "right.thumb.tip.x",
                        "right.thumb.tip.y", "right.thumb.tip.z", "right.index.tip.x", "right.index.tip.y",
                        "right.index.tip.z"]
    assert [float(v) for v in table[1]] == [0.0, 0, 0, 1.5, *FREE_SIDE, *dome_top]
    assert table[-1][:4] == ["0.05", "", "", ""]
    store.close()


def test_point_rows_of_a_state_record_the_hub_could_not_take_ride_with_the_next():
    core = two_fingers()
    core.apply(RecordEvery(1), 0)
    first = core.tick([tracker(1, 0, FREE, points={THUMB: FREE_SIDE})], 0).state
    core.unsent(first)
    second = state_map(core.tick((), MS).state)
    assert [row[0] for row in second["point_rows"]] == [0, 1]
    assert [row[0] for row in second["trajectory"]] == [0, 1]
