"""Pick and place in a two-tool Simulation: the grasp, the carry and the placement against the real
god-objects (one per finger, neither colliding with the other), each finger's cues its own."""

import pytest

from server.core.cues import Vibration
from server.loop.simulation import Simulation
from scenarios.pick_place import BLOCK, BLOCK_SIDE, BLOCK_START, INDEX, THUMB, PickPlace
from tests.scenarios.driving import line

HALF = BLOCK_SIDE / 2
R = 0.06
X0, Y0 = BLOCK_START
TOUCH = HALF + R  # a fingertip centre resting on a side face


class Hand:
    """Drives the two fingers as one tracker source sends them (index as pos, thumb in points)."""

    def __init__(self, sim):
        self.sim, self.seq = sim, 0

    def move(self, index_path, thumb_path):
        out = []
        for i, t in zip(index_path, thumb_path):
            self.seq += 1
            self.sim.offer("hand", self.seq, i, points={THUMB: t})
            out.append(self.sim.step())
        return out


def pinch(centre, gap):
    """Index on the +y side, thumb on the −y side of `centre`, each `gap` from its face's contact
    position (negative: pressed in)."""
    x, y, z = centre
    return (x, y + TOUCH + gap, z), (x, y - TOUCH - gap, z)


def grasp(hand, press=0.03, dwell=60):
    """Fingers come in from 0.1 outside and press `press` into the block, then hold `dwell` ticks."""
    start = (X0, Y0, HALF)
    i0, t0 = pinch(start, 0.1)
    i1, t1 = pinch(start, -press)
    return hand.move(line(i0, i1, 100) + [i1] * dwell, line(t0, t1, 100) + [t1] * dwell)


def make():
    sim = Simulation(PickPlace())
    return sim, sim.scenario, Hand(sim)


def test_the_scenario_gets_two_tools_index_first():
    sim, _, _ = make()
    assert [t.name for t in sim.data.tools] == [INDEX, THUMB]


def test_pressing_both_fingers_in_from_opposite_sides_grasps_and_each_finger_feels_its_own_contact():
    sim, sc, hand = make()
    results = grasp(hand)
    assert sc.phase == "held" and [e["name"] for e in sim.data.events] == ["grasp"]
    last = results[-1]
    index, thumb = last.tools
    assert index.contact and thumb.contact and BLOCK in index.touching and BLOCK in thumb.touching
    assert index.proxy[1] == pytest.approx(Y0 + TOUCH, abs=1e-9), "each proxy rests on its own face"
    assert thumb.proxy[1] == pytest.approx(Y0 - TOUCH, abs=1e-9)
    assert last.output.cues == (Vibration(100.0),) and last.output.tool_cues == {THUMB: (Vibration(100.0),)}
    assert last.output.held == BLOCK


def test_touching_with_the_index_only_cues_only_the_index():
    sim, sc, hand = make()
    i0, _ = pinch((X0, Y0, HALF), 0.1)
    i1, _ = pinch((X0, Y0, HALF), -0.01)
    far = (X0, Y0 - 1.0, 1.0)
    last = hand.move(line(i0, i1, 100) + [i1] * 60, [far] * 160)[-1]
    assert sc.phase == "idle"
    assert last.output.cues == (Vibration(40.0),) and last.output.tool_cues == {THUMB: ()}


def test_a_light_touch_from_both_sides_is_no_grasp():
    sim, sc, hand = make()
    grasp(hand, press=0.005)
    assert sc.phase == "idle"


def test_carry_to_the_target_and_open_the_fingers_places_the_block():
    sim, sc, hand = make()
    grasp(hand)
    held_at = sim.data.moved[BLOCK].pos
    assert held_at == pytest.approx((X0, Y0, HALF), abs=1e-9), "no jump at the grasp"
    # lift 0.4, carry to the target (0, −0.9), set down to 0.02 above the table
    route = [(X0, Y0, HALF), (X0, Y0, HALF + 0.4), (0.0, -0.9, HALF + 0.4), (0.0, -0.9, HALF + 0.02)]
    centres = [p for a, b in zip(route, route[1:]) for p in line(a, b, 300)]
    results = hand.move(*zip(*(pinch(c, -0.03) for c in centres)))
    assert sc.phase == "held", "the grasp held all the way"
    assert sim.data.moved[BLOCK].pos == pytest.approx((0.0, -0.9, HALF + 0.02), abs=0.01)
    assert all(BLOCK in r.tools[0].touching and BLOCK in r.tools[1].touching for r in results[-50:])
    # open: both fingers back out
    open_i, open_t = pinch(centres[-1], 0.1)
    press_i, press_t = pinch(centres[-1], -0.03)
    hand.move(line(press_i, open_i, 50), line(press_t, open_t, 50))
    assert sc.phase == "placed"
    assert sim.data.moved[BLOCK].pos == pytest.approx((0.0, -0.9, HALF), abs=0.01), "it dropped onto the target"
    place = next(e for e in sim.data.events if e["name"] == "place")
    assert place["error"] < 0.01


def test_the_thumbs_tracker_lost_drops_the_block():
    sim, sc, hand = make()
    grasp(hand)
    i, t = pinch((X0, Y0, HALF + 0.3), -0.03)
    hand.move(line(pinch((X0, Y0, HALF), -0.03)[0], i, 100), line(pinch((X0, Y0, HALF), -0.03)[1], t, 100))
    assert sc.phase == "held"
    # the source streams with a ttl, then stops
    hand.seq += 1
    sim.offer("hand", hand.seq, i, points={THUMB: t}, ttl_ms=40)
    results = [sim.step() for _ in range(60)]
    assert sc.phase == "idle" and sc.drops == 1
    lost = [e for e in sim.data.events if e["name"] == "drop"]
    assert lost and lost[-1]["reason"] == "tracking_lost"
    assert results[-1].output.cues == () and results[-1].output.tool_cues == {THUMB: ()}, "no cue stays on"
    assert sim.data.moved[BLOCK].pos[2] == HALF


def test_a_fast_carry_at_a_trackers_rate_keeps_the_grasp():
    """Samples at 120 Hz (held 8-9 ticks each) moving at 3 units/s: each sample jumps the HIPs
    0.025 ahead of the block, which follows one tick later; the leading finger's own press dips
    below the release depth in that tick, the grip (the two HIPs' distance) does not."""
    sim, sc, hand = make()
    grasp(hand)
    start, end = (X0, Y0, HALF + 0.02), (X0, Y0 - 1.5, HALF + 0.02)
    centres = [c for c in line(start, end, 60) for _ in range(8)]  # 60 samples over 0.48 s, 8 ticks each
    hand.move(*zip(*(pinch(c, -0.03) for c in centres)))
    assert sc.phase == "held" and sc.drops == 0
    assert sim.data.moved[BLOCK].pos == pytest.approx(end, abs=1e-6)


def test_the_grip_cue_stays_steady_through_a_fast_carry():
    """4 units/s at 120 Hz: each sample jumps 0.033, more than the 0.03 pressed in, so the leading
    finger's proxy leaves the face for a tick at every sample; the grasp and its cue hold."""
    sim, sc, hand = make()
    grasp(hand)
    start, end = (X0, Y0, HALF + 0.02), (X0, Y0 - 1.5, HALF + 0.02)
    centres = [c for c in line(start, end, 45) for _ in range(8)]
    results = hand.move(*zip(*(pinch(c, -0.03) for c in centres)))
    assert not any(r.cues_changed for r in results), "one cue all the way: no device command per sample"
    assert {r.output.tool_cues[THUMB] for r in results} == {(Vibration(100.0),)}
    assert sc.phase == "held"
    assert any(BLOCK not in r.tools[1].touching for r in results), "the thumb did leave the face (the case)"


def test_a_one_point_rig_moves_the_index_only_and_the_hud_says_the_thumb_is_not_tracked():
    """A mouse sends the primary point only: the thumb's tool rests at home, undriven. The HUD must
    not ask for a grasp the rig cannot make (issue 34.6); a tracker that sends the thumb too lifts it."""
    sim, sc, hand = make()
    for k in range(20):
        sim.offer("mouse", k, (X0, Y0 + TOUCH - 0.03, HALF))  # the index pressed into the block
        out = sim.step()
    assert [v.driven for v in out.tools] == [True, False]
    assert "not tracked: right.thumb.tip" in out.output.hud and out.output.values["missing"] == [THUMB]
    assert sc.phase == "idle" and not sim.data.events
    sim.release("mouse")
    grasp(hand)
    assert sc.phase == "held" and sim.step().output.hud == "Place it on the green target"
