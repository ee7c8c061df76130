"""Scenario 7 (thesis §4.2.4): perspective scene, the nearest hole chosen again every tick,
intensity and pulse rate linear in the distance (and reversed), insertion into a hole that fits,
the per-trial metrics against the scripted path."""

import math

import pytest

from server.core.cues import PulseTrain, Vibration
from server.core.scenario import Trial
from scenarios.peg_in_hole import PegInHole, hole_centre
from scenarios.positioning import ITEMS
from scenarios.registry import create
from server.loop.simulation import Simulation
from tests.scenarios.driving import drive as run, finished, line, metrics_of

CUBE_A, SPHERE, CUBE_B = ITEMS
HANG = 0.15 + 0.06  # the carried object hangs this far below the proxy


def make(**params):
    sim = Simulation(create("peg-in-hole-v1", **params))
    return sim, sim.scenario


def pick(sim, item=CUBE_A):
    x, y = item.start
    return run(sim, [(x, y, 0.6)] * 3 + line((x, y, 0.6), (x, y, 0.34), 30))


def over(hole_item, carried=CUBE_A, dz=0.0):
    """The HIP position that carries `carried` to `hole_item`'s hole centre (raised by dz)."""
    x, y, z = hole_centre(hole_item, carried)
    return x, y, z + HANG + dz


def test_scene_is_the_positioning_table_seen_in_perspective():
    sim, _ = make()
    ids = {o.id for o in sim.scene.objects}
    assert {"table", "cube_a", "sphere", "cube_b", "cube_a_hole", "sphere_rim"} <= ids
    assert sim.scene.camera.projection == "perspective", "all three dimensions visible; the client may orbit"


def test_the_nearest_hole_is_chosen_again_every_tick():
    sim, sc = make()
    pick(sim, CUBE_B)
    # sweep the carried cube over the three holes, left to right, at a height above all of them
    y_path = [(-0.0, y / 100, 1.2) for y in range(-200, 201, 2)]
    results = run(sim, y_path)
    seen = [r.output.values.get("nearest_hole") for r in results]
    order = [h for k, h in enumerate(seen) if k == 0 or h != seen[k - 1]]
    assert order == ["cube_a", "sphere", "cube_b"], order
    # at every tick the chosen hole is the one with the least Euclidean distance
    for r in results[::10]:
        carried = (r.proxy[0], r.proxy[1], r.proxy[2] - HANG)
        best = min(ITEMS, key=lambda h: math.dist(carried, hole_centre(h, CUBE_B)))
        assert r.output.values["nearest_hole"] == best.id
        assert r.output.values["distance"] == pytest.approx(math.dist(carried, hole_centre(best, CUBE_B)), abs=1e-6)
    assert [e["hole"] for e in sim.data.events if e["name"] == "nearest_hole"] == ["cube_b", "cube_a", "sphere", "cube_b"]


@pytest.mark.parametrize("reverse", [False, True])
def test_intensity_and_pulse_rate_are_linear_in_the_distance(reverse):
    sim, sc = make(reverse=reverse, boundary=2.0)
    pick(sim, CUBE_A)
    cues = {}
    for d in (0.5, 1.0, 1.5, 2.1):
        cues[d] = run(sim, [over(CUBE_A, dz=d)] * 3)[-1].output.cues
    assert cues[2.1] == (), "no cue beyond the boundary"
    c5, c10, c15 = cues[0.5][0], cues[1.0][0], cues[1.5][0]
    if not reverse:
        assert c5.intensity_pct > c10.intensity_pct > c15.intensity_pct and c5.t_off_ms < c10.t_off_ms < c15.t_off_ms
        assert c10 == PulseTrain(50.0, 250.0, 65.0), "halfway: half the pause, halfway intensity"
        # linear: equal steps in distance, equal steps in the cue
        assert c5.intensity_pct - c10.intensity_pct == pytest.approx(c10.intensity_pct - c15.intensity_pct)
        assert c10.t_off_ms - c5.t_off_ms == pytest.approx(c15.t_off_ms - c10.t_off_ms)
    else:
        assert c5.intensity_pct < c10.intensity_pct < c15.intensity_pct and c5.t_off_ms > c10.t_off_ms > c15.t_off_ms
        assert c5.intensity_pct - c10.intensity_pct == pytest.approx(c10.intensity_pct - c15.intensity_pct)


@pytest.mark.parametrize("reverse, expected", [(False, (Vibration(100.0),)), (True, ())])
def test_at_the_hole_strongest_or_in_reverse_silent(reverse, expected):
    sim, sc = make(reverse=reverse)
    pick(sim, CUBE_B)
    # a cube does not fit the round hole: the fingertip rests on its rim, the cube at the hole's centre
    at = run(sim, [over(SPHERE, CUBE_B, dz=0.3)] * 2 + line(over(SPHERE, CUBE_B, dz=0.3),
                                                             over(SPHERE, CUBE_B, dz=-0.03), 60))[-1]
    assert sc.carried is CUBE_B and at.output.values["nearest_hole"] == "sphere"
    assert at.output.values["distance"] == pytest.approx(0.0, abs=1e-6)
    assert at.output.cues == expected


def test_insertion_into_its_own_hole_with_metrics_of_the_path():
    sim, sc = make()
    results = pick(sim, CUBE_A)
    pick_tick = next(e["tick"] for e in sim.data.events if e["name"] == "pick")
    above = over(CUBE_A, dz=0.6)
    rim = over(CUBE_A, dz=-0.03)  # below the rim top: the proxy rests on the rim, the cube is in
    results += run(sim, line(results[-1].hip, above, 400) + line(above, rim, 200))
    done = next(e for e in sim.data.events if e["name"] == "trial_done")
    assert done["object"] == "cube_a" and done["hole"] == "cube_a" and done["own_hole"] is True
    assert done["completion_s"] == pytest.approx((done["tick"] - pick_tick) / 1000, abs=1e-9)
    carried = [(r.proxy[0], r.proxy[1], max(0.15, r.proxy[2] - HANG)) for r in results[pick_tick:done["tick"] + 1]]
    assert done["path_length"] == pytest.approx(sum(math.dist(a, b) for a, b in zip(carried, carried[1:])), abs=1e-6)
    assert finished(results) == [(done["tick"], metrics_of(done))], "the insertion is the step's `finished` too"
    assert sim.data.moved["cube_a"].pos == (*CUBE_A.hole_at, 0.15), "it drops to the bottom and stays"
    assert "cube_a" in sim.data.untouchable
    after = run(sim, [above])[-1]
    assert after.output.cues == () and after.output.values["last_hole"] == "cube_a"


def test_a_cube_fits_the_round_hole_only_when_the_holes_are_scaled():
    sim, sc = make()
    pick(sim, CUBE_B)
    into_round = over(SPHERE, CUBE_B, dz=-0.03)
    run(sim, line(over(SPHERE, CUBE_B, dz=0.6), into_round, 100))
    assert sc.carried is CUBE_B, "a cube's corners do not fit the round hole at scale 1"
    sim.input("hole_scale", "press", 1.5)
    run(sim, [over(SPHERE, CUBE_B, dz=0.6)] * 2 + line(over(SPHERE, CUBE_B, dz=0.6), into_round, 100))
    done = next(e for e in sim.data.events if e["name"] == "trial_done")
    assert done["hole"] == "sphere" and done["own_hole"] is False
    # the round hole is taken: carrying the sphere, the nearest free hole is never it
    pick(sim, SPHERE)
    r = run(sim, [over(SPHERE, SPHERE, dz=0.3)] * 2)[-1]
    assert r.output.values["nearest_hole"] != "sphere"


def test_a_trial_grasps_only_its_object_and_r_clears_the_table_outside_trials():
    sim, sc = make()
    sim.set_trial(Trial.parse(PegInHole.TRIAL_PARAMS, "main", {"object": "sphere", "reverse": True}))
    pick(sim, CUBE_A)
    assert sc.carried is None, "not this trial's object"
    pick(sim, SPHERE)
    assert sc.carried is SPHERE and sc._reverse() is True
    sim.set_trial(None)
    sim.step()
    assert sc.carried is None and "sphere" not in sim.data.untouchable, "a new trial (or none) clears the table"
    pick(sim, CUBE_A)
    run(sim, line(over(CUBE_A, dz=0.6), over(CUBE_A, dz=-0.03), 100))
    assert sc.placed == {"cube_a": "cube_a"}
    sim.input("r", "down")
    sim.step()
    assert sc.placed == {} and sim.data.moved["cube_a"].pos == (*CUBE_A.start, 0.15) and "cube_a" not in sim.data.untouchable
