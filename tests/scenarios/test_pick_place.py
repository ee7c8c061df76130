"""Pick and place with two fingers: the grasp needs both contacts on opposite sides and the
squeeze; the held block follows the fingers' midpoint; a release over the target places it (the
trial's metrics), elsewhere it is a drop. Hand-made contexts here (the rule itself); a two-tool
Simulation in test_pick_place_sim.py (the rule against the real god-objects)."""

import math
from types import SimpleNamespace

import pytest

from server.core.cues import Vibration
from server.core.scenario import ParamError, Trial
from scenarios.pick_place import (BLOCK, BLOCK_SIDE, BLOCK_START, INDEX, THUMB, PickPlace, opposite_angle_deg,
                                  press_depth)
from scenarios.registry import create, resolve

HALF = BLOCK_SIDE / 2
R = 0.06  # proxy radius
START = (*BLOCK_START, HALF)


def tool(name, proxy, press=0.0, towards=(0.0, 0.0, 0.0), contact=True, touching=(BLOCK,), lost=False, driven=None):
    """A tool whose proxy rests at `proxy` and whose HIP is pressed `press` further along `towards`
    (driven by a tracker unless lost, as server/core/tool.py has it)."""
    hip = tuple(p + press * d for p, d in zip(proxy, towards))
    return SimpleNamespace(name=name, hip=hip, proxy=proxy, contact=contact, touching=frozenset(touching),
                           force=(0.0, 0.0, 0.0), lost=lost, driven=not lost if driven is None else driven)


def grip(centre, press, angle_deg=180.0, **kw):
    """Index on the +y face of a block at `centre`, thumb `angle_deg` around from it (about z),
    both pressed `press` toward the centre."""
    tools = []
    for name, a in ((INDEX, 0.0), (THUMB, angle_deg)):
        d = (-math.sin(math.radians(a)), math.cos(math.radians(a)), 0.0)  # outward normal, a = 0 → +y
        proxy = tuple(c + (HALF + R) * n for c, n in zip(centre, d))
        tools.append(tool(name, proxy, press, tuple(-n for n in d), **kw.get(name, {})))
    return tools


class Driver:
    def __init__(self, sc, tick_hz=1000):
        self.sc, self.tick, self.tick_hz = sc, 0, tick_hz

    def step(self, tools, refusals=()):
        ctx = SimpleNamespace(tick=self.tick, t_s=self.tick / self.tick_hz, tools=tuple(tools), refusals=refusals,
                              hip=tools[0].hip, proxy=tools[0].proxy, contact=tools[0].contact,
                              touching=tools[0].touching, nearest=None, sticking=False)
        self.tick += 1
        return self.sc.step(ctx)


def away():
    return [tool(INDEX, (0.0, 0.0, 1.0), contact=False, touching=()),
            tool(THUMB, (0.0, 0.3, 1.0), contact=False, touching=())]


def test_registered_declares_two_fingers_and_builds_its_scene():
    assert resolve("pick-place").id == "pick-place-v1"
    sc = create("pick-place")
    assert PickPlace.fingers == ("right.index.tip", "right.thumb.tip")
    scene = sc.build_scene()
    assert scene.object(BLOCK).haptic and not scene.object("target").haptic
    assert scene.object(BLOCK).pose.pos == START
    with pytest.raises(ParamError, match="squeeze"):
        create("pick-place", squeeze=0.0)


def test_geometry_helpers():
    assert opposite_angle_deg((0, 0, 0), (0, 1, 0), (0, -2, 0)) == pytest.approx(180.0)
    assert opposite_angle_deg((0, 0, 0), (0, 1, 0), (1, 0, 0)) == pytest.approx(90.0)
    assert opposite_angle_deg((0, 0, 0), (0, 0, 0), (1, 0, 0)) == 0.0
    assert press_depth(tool(INDEX, (0, 0, 0), 0.03, (0, 0, -1))) == pytest.approx(0.03)


def test_touching_without_the_squeeze_is_no_grasp_but_each_finger_feels_its_own_contact():
    sc = PickPlace()
    d = Driver(sc)
    out = d.step(grip(START, 0.01))
    assert sc.phase == "idle" and out.held is None
    assert out.cues == (Vibration(40.0),) and out.tool_cues == {THUMB: (Vibration(40.0),)}
    only_index = grip(START, 0.03)
    only_index[1] = tool(THUMB, (0.0, 0.0, 1.0), contact=False, touching=())
    out = d.step(only_index)
    assert sc.phase == "idle", "one finger pressing is no grasp"
    assert out.cues == (Vibration(40.0),) and out.tool_cues == {THUMB: ()}, "the thumb touches nothing: no cue"


@pytest.mark.parametrize("angle, grasped", [(180.0, True), (140.0, True), (130.0, False), (90.0, False)])
def test_the_grasp_needs_roughly_opposite_sides(angle, grasped):
    sc = PickPlace(opposite_deg=45.0)
    Driver(sc).step(grip(START, 0.03, angle))
    assert (sc.phase == "held") is grasped


def test_a_lost_finger_or_one_out_of_contact_grasps_nothing():
    for kw in ({THUMB: {"lost": True}}, {THUMB: {"contact": False}}, {INDEX: {"touching": ("table",)}}):
        sc = PickPlace()
        Driver(sc).step(grip(START, 0.03, **kw))
        assert sc.phase == "idle", kw


def test_held_block_follows_the_midpoint_keeping_its_grasp_offset_and_stays_above_the_table():
    sc = PickPlace()
    d = Driver(sc)
    first = grip(START, 0.03)
    first = [tool(t.name, (t.proxy[0], t.proxy[1], t.proxy[2] + 0.05), 0.03, (0, -math.copysign(1, t.proxy[1] - START[1]), 0))
             for t in first]  # grasped 0.05 above the block's centre
    out = d.step(first)
    assert sc.phase == "held" and out.held == BLOCK and [e["name"] for e in out.events] == ["grasp"]
    assert out.cues == (Vibration(100.0),) and out.tool_cues == {THUMB: (Vibration(100.0),)}
    lifted = (0.2, 0.1, 0.9)
    moved = [tool(t.name, tuple(p + m - s for p, m, s in zip(t.proxy, lifted, START)), 0.03,
                  (0, -math.copysign(1, t.proxy[1] - START[1]), 0)) for t in first]
    out = d.step(moved)
    assert out.poses[BLOCK].pos == pytest.approx(lifted), "the block keeps where it was grasped: no jump"
    low = [tool(t.name, (t.proxy[0], t.proxy[1], -0.5), 0.03, (0, -math.copysign(1, t.proxy[1] - START[1]), 0))
           for t in moved]
    out = d.step(low)
    assert out.poses[BLOCK].pos[2] == HALF, "never into the table"


def test_the_grasp_holds_down_to_half_the_squeeze_then_opens_to_a_drop():
    sc = PickPlace(squeeze=0.02)
    d = Driver(sc)
    d.step(grip(START, 0.02))
    assert sc.phase == "held"
    d.step(grip(START, 0.011))
    assert sc.phase == "held", "hysteresis: a grasp at the threshold does not chatter"
    out = d.step(grip(START, 0.009))
    assert sc.phase == "idle" and sc.drops == 1
    (drop,) = out.events
    assert drop["name"] == "drop" and drop["reason"] == "opened"
    assert drop["error"] == pytest.approx(math.dist(BLOCK_START, (0.0, -0.9)))


def carry_and_release(d, sc, to_xy, press=0.03, lift=0.4):
    """Grasp at the start, carry the block to `to_xy` `lift` above the table, let go there."""
    outs = [d.step(grip(START, press))]
    for k in range(1, 51):
        f = k / 50
        c = (START[0] + f * (to_xy[0] - START[0]), START[1] + f * (to_xy[1] - START[1]), HALF + f * lift)
        outs.append(d.step(grip(c, press)))
    c = (*to_xy, HALF + lift)
    outs.append(d.step(grip(c, 0.0)))  # fingers open: pressing nothing
    return outs


def test_released_over_the_target_it_rests_there_and_the_trial_ends_with_its_metrics():
    sc = PickPlace()
    sc.set_trial(Trial.parse(PickPlace.TRIAL_PARAMS, "main", {"target_x": 0.0, "target_y": -0.9}))
    d = Driver(sc)
    for _ in range(200):
        d.step(away())  # 0.2 s before the grasp
    outs = carry_and_release(d, sc, (0.05, -0.9))
    last = outs[-1]
    assert sc.phase == "placed" and last.poses[BLOCK].pos == pytest.approx((0.05, -0.9, HALF))
    assert last.finished == {"time_to_grasp_s": 0.2, "time_to_place_s": 0.051, "placement_error": pytest.approx(0.05),
                             "drops": 0}
    assert [e["name"] for e in last.events] == ["place", "trial_done"]
    assert last.hud == "Done" and last.held is None


def test_a_drop_off_target_counts_and_the_block_can_be_grasped_again():
    sc = PickPlace()
    sc.set_trial(Trial.parse(PickPlace.TRIAL_PARAMS, "main", {"target_x": 0.0, "target_y": -0.9}))
    d = Driver(sc)
    outs = carry_and_release(d, sc, (0.0, 0.0))
    assert sc.phase == "idle" and sc.drops == 1 and outs[-1].finished is None
    assert sc.centre == pytest.approx((0.0, 0.0, HALF), abs=1e-12)
    d.step(grip(sc.centre, 0.03))
    assert sc.phase == "held" and sc.t_grasp == 0.0, "time to grasp is the first grasp's"


def test_a_drop_beyond_the_tables_edge_puts_the_block_back_at_its_start():
    sc = PickPlace()
    d = Driver(sc)
    outs = carry_and_release(d, sc, (0.0, 2.3))  # the table reaches y = ±2
    assert sc.phase == "idle" and sc.drops == 1 and sc.centre == START
    assert outs[-1].poses[BLOCK].pos == START
    (drop,) = outs[-1].events
    assert drop["off_table"] is True and drop["error"] == pytest.approx(3.2)


def test_tracking_lost_while_held_drops_the_block_and_says_why():
    sc = PickPlace()
    d = Driver(sc)
    d.step(grip(START, 0.03))
    out = d.step(grip(START, 0.03, **{THUMB: {"lost": True}}))
    assert sc.phase == "idle" and out.events[0]["reason"] == "tracking_lost"
    assert out.tool_cues == {THUMB: ()}, "no cue on a lost finger's device"


def test_without_a_thumb_the_hud_says_what_is_missing():
    sc = PickPlace()
    out = Driver(sc).step([tool(INDEX, START)])
    assert "two tracked fingers" in out.hud and out.values["missing"] == [THUMB]
    assert out.cues == () and out.tool_cues == {}


def test_a_thumb_no_tracker_drives_is_named_in_the_hud_and_nothing_is_grasped():
    """A one-point rig (a mouse): the thumb's tool rests at home, undriven. Even pressed into the
    block (as home could be), it grasps nothing, and the HUD says why instead of "Grasp …"."""
    sc = PickPlace()
    d = Driver(sc)
    for _ in range(3):
        out = d.step(grip(START, 0.03, **{THUMB: {"driven": False}}))
    assert sc.phase == "idle" and not out.events
    assert "two tracked fingers" in out.hud and "not tracked: right.thumb.tip" in out.hud and "mouse" in out.hud
    assert out.values["missing"] == [THUMB]
    # once a tracker drives the thumb, the grasp works
    d.step(grip(START, 0.03))
    assert sc.phase == "held"


def test_space_puts_the_block_back_after_a_placement_outside_trials():
    sc = PickPlace()
    d = Driver(sc)
    carry_and_release(d, sc, (0.0, -0.9))
    assert sc.phase == "placed" and d.step(away()).hud.startswith("Placed")
    sc.on_input(" ", "down")
    out = d.step(away())
    assert sc.phase == "idle" and out.poses[BLOCK].pos == START


def test_a_trial_moves_the_target():
    sc = PickPlace()
    sc.set_trial(Trial.parse(PickPlace.TRIAL_PARAMS, "main", {"target_x": 0.6, "target_y": -1.3}))
    out = Driver(sc).step(away())
    assert out.poses["target"].pos == (0.6, -1.3, 0.0) and sc.target == (0.6, -1.3)


def test_the_grasp_holds_on_the_grip_not_on_each_fingers_press_or_contact():
    sc = PickPlace(squeeze=0.02)
    d = Driver(sc)
    d.step(grip(START, 0.03))
    assert sc.phase == "held"
    lopsided = grip(START, 0.0)
    lopsided[1] = grip(START, 0.025)[1]  # the index rests on its face, the thumb presses 0.025: grip 0.025
    out = d.step(lopsided)
    assert sc.phase == "held" and out.values["grip"] == pytest.approx(0.025)
    d.step(grip(START, 0.03, **{INDEX: {"contact": False, "touching": ()}}))
    assert sc.phase == "held", "a tick off the face with the grip closed (a fast sample) keeps the block"
    d.step(grip(START, 0.005))
    assert sc.phase == "idle" and sc.drops == 1, "the grip opened"
