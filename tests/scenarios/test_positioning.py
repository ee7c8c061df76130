"""Scenario 6 (thesis §4.2): grasp, arrow, hold 2 s → GO, insertion, next object, the
per-trial metrics against the scripted path, cue laws on the carried object, moving and scaled
holes."""

import math

import pytest

from server.core.cues import PulseTrain, Tilt, Vibration
from server.core.scenario import ParamError, Trial
from scenarios.positioning import ITEMS, Positioning, inserted, tube_mesh
from server.loop.simulation import Simulation
from tests.scenarios.driving import drive as run_path, finished, line, metrics_of

HANG = 0.15 + 0.06  # the carried object hangs this far below the proxy


def make(**params):
    sim = Simulation(Positioning(**params))
    return sim, sim.scenario


def pick(sim, item=ITEMS[0]):
    x, y = item.start
    return run_path(sim, [(x, y, 0.6)] * 3 + line((x, y, 0.6), (x, y, 0.34), 30))


def test_scene_models_no_more_than_the_task_needs():
    sim, _ = make()
    scene = sim.scene
    legs = [o for o in scene.objects if o.id.startswith("leg_")]
    assert len(legs) == 4 and all(not o.haptic and o.shape.height == 5.0 and o.shape.radius == 0.05 for o in legs)
    for item in ITEMS:
        tube, rim = scene.object(f"{item.id}_hole"), scene.object(f"{item.id}_rim")
        assert tube.shape.type == "mesh" and not tube.haptic, "tubes are drawn, not touched"
        assert rim.haptic and not rim.visible, "a solid primitive of the tube's outer size is touched"
    assert scene.camera.projection == "orthographic" and scene.camera.position[0] > 0  # side view: x hidden


@pytest.mark.parametrize("hole", [ITEMS[0].hole, ITEMS[1].hole])
def test_tube_meshes_have_the_spec_dimensions(hole):
    import numpy as np

    v = np.array(tube_mesh(hole).vertices)
    assert v[:, 2].min() == pytest.approx(0.0) and v[:, 2].max() == pytest.approx(hole.height)
    radial = np.hypot(v[:, 0], v[:, 1]) if hole.kind == "round" else np.maximum(abs(v[:, 0]), abs(v[:, 1]))
    assert radial.max() == pytest.approx(hole.outer, abs=1e-6) and radial.min() == pytest.approx(hole.inner, abs=1e-6)


def test_grasp_attaches_the_object_shows_the_arrow_and_stops_touching_it():
    sim, sc = make()
    pick(sim)
    x, y = ITEMS[0].start
    last = run_path(sim, [(x, y, 0.9)] * 3)[-1]
    assert sc.phase == "carry" and last.output.hud == "Bring it to the arrow"
    assert "cube_a" in sim.data.untouchable and sim.data.visibility["arrow_head"] is True
    assert sim.data.moved["cube_a"].pos == pytest.approx((x, y, 0.9 - HANG))
    assert [e["name"] for e in sim.data.events] == ["pick"]


def test_hold_two_seconds_then_go_then_insert_with_metrics_of_the_path():
    sim, sc = make(cue="none")
    item = ITEMS[0]
    results = pick(sim)
    t = sc.target(item)
    above = (t[0], t[1], t[2] + HANG)
    path = line((item.start[0], item.start[1], 0.34), above, 400)
    results += run_path(sim, path + [above] * 2100)
    ticks = {e["name"]: e["tick"] for e in sim.data.events}
    assert ticks["go"] - ticks["reached"] == 2000, "GO after exactly 2 s at the target"
    assert results[ticks["go"] - 1].output.hud.startswith("Hold") and results[ticks["go"]].output.hud == "GO"
    into = (t[0], t[1], item.hole.height + 0.1)  # the HIP stays above the rim: the proxy is free
    results += run_path(sim, line(above, into, 100))
    assert sc.phase == "inserted"
    done = next(e for e in sim.data.events if e["name"] == "trial_done")
    # from the grasp on, the free proxy is the HIP and the object hangs 0.21 below it (not below the table)
    carried = [(r.hip[0], r.hip[1], max(item.half, r.hip[2] - HANG)) for r in results[ticks["pick"]:done["tick"] + 1]]
    assert done["path_length"] == pytest.approx(sum(math.dist(a, b) for a, b in zip(carried, carried[1:])), abs=1e-6)
    assert done["time_to_target_s"] == pytest.approx((ticks["reached"] - ticks["pick"]) / 1000, abs=1e-9)
    assert done["completion_s"] == pytest.approx((done["tick"] - ticks["pick"]) / 1000, abs=1e-9)
    assert done["hold_error_mean"] < 0.05 and done["hold_depth_error_mean"] < 0.05
    assert finished(results) == [(done["tick"], metrics_of(done))], "the insertion is the step's `finished` too"


def test_leaving_the_target_restarts_the_hold_and_entering_the_hole_before_go_does_not_count():
    sim, sc = make(cue="none")
    item = ITEMS[0]
    pick(sim)
    t = sc.target(item)
    above = (t[0], t[1], t[2] + HANG)
    run_path(sim, line((item.start[0], item.start[1], 0.34), above, 100) + [above] * 1500)
    run_path(sim, [(t[0] + 0.2, t[1], t[2] + HANG)] * 5)
    run_path(sim, [above] * 1500)
    assert sc.phase == "carry", "the hold restarted when the object left the target"
    run_path(sim, line(above, (t[0], t[1], 0.6), 50))
    assert sc.phase == "carry", "no insertion before GO"


def test_space_brings_the_next_object_only_after_insertion():
    sim, sc = make()
    sim.input(" ", "down")
    sim.step()
    assert sc.index == 0
    sc.phase = "inserted"
    sim.input(" ", "down")
    sim.step()
    assert sc.index == 1 and sc.phase == "idle" and sim.data.moved["sphere"].pos == (*ITEMS[1].start, 0.15)


@pytest.mark.parametrize("cue, depth, expected", [
    ("P1", 0.6, PulseTrain(50.0, 300.0)), ("P2", 0.6, PulseTrain(50.0, 75.0)),
    ("continuous-at-target", 0.6, PulseTrain(50.0, 300.0)), ("none-at-target", 0.6, PulseTrain(50.0, 700.0)),
    ("P1", 0.0, Vibration(100.0)), ("none", 0.6, None),
])
def test_the_carried_objects_depth_drives_the_cue(cue, depth, expected):
    sim, sc = make(cue=cue)
    item = ITEMS[0]
    pick(sim)
    t = sc.target(item)
    last = run_path(sim, [(t[0] + depth, t[1], t[2] + HANG)] * 5)[-1]
    assert last.output.cues == ((expected,) if expected else ())


def test_p3_switches_after_the_first_reach():
    sim, sc = make(cue="P3")
    item = ITEMS[0]
    pick(sim)
    t = sc.target(item)
    before = run_path(sim, [(t[0] + 0.6, t[1], t[2] + HANG)] * 3)[-1]
    run_path(sim, [(t[0], t[1], t[2] + HANG)] * 3)
    near = run_path(sim, [(t[0] + 0.08, t[1], t[2] + HANG)] * 3)[-1]
    far = run_path(sim, [(t[0] + 0.6, t[1], t[2] + HANG)] * 3)[-1]
    assert before.output.cues == (PulseTrain(50.0, 300.0),)
    (cue,) = near.output.cues
    assert isinstance(cue, PulseTrain) and cue.t_off_ms == pytest.approx(80.0)
    assert far.output.cues == ()


def test_3dof_guidance_on_the_carried_object():
    sim, sc = make(cue="3dof")
    item = ITEMS[0]
    pick(sim)
    t = sc.target(item)
    last = run_path(sim, [(t[0] + 0.5, t[1] + 0.5, t[2] + HANG - 0.2)] * 3)[-1]
    assert last.output.cues == (Tilt(135.0, 100.0), PulseTrain(50.0, 100.0))


def test_trial_selects_object_and_cue_and_bad_values_are_named():
    sim, sc = make()
    pick(sim)  # cube_a grasped and lifted away ...
    run_path(sim, [(0.0, 0.0, 1.5)] * 3)
    sim.set_trial(Trial.parse(Positioning.TRIAL_PARAMS, "main", {"object": "sphere", "cue": "P2"}))
    sim.step()
    assert sc.index == 1 and sc.guide.pattern == "P2"
    assert sim.data.moved["cube_a"].pos == (*ITEMS[0].start, 0.15) and "cube_a" not in sim.data.untouchable, "a clean table"
    with pytest.raises(ParamError, match="object must be one of"):
        Trial.parse(Positioning.TRIAL_PARAMS, "main", {"object": "pyramid"})


def test_moving_holes_and_hole_scale():
    sim, sc = make(hole_speed=0.01)
    run_path(sim, [(0.0, 0.0, 2.0)] * 1001)
    assert sim.data.moved["cube_a_hole"].pos[1] == pytest.approx(ITEMS[0].hole_at[1] + 0.01, abs=1e-5)
    assert sc.target(ITEMS[0])[1] == pytest.approx(ITEMS[0].hole_at[1] + 0.01, abs=1e-5)
    item, hole = ITEMS[0], ITEMS[0].hole_at
    off = (hole[0] + 0.09, hole[1], 0.3)
    assert not inserted(item, off, hole, 1.0) and inserted(item, off, hole, 1.5)
    sim.input("hole_scale", "press", 1.5)
    sim.step()
    assert sc.scale == 1.5 and sim.data.events[-1]["name"] == "hole_scale"
    assert sim.data.scales["cube_a_hole"] == (1.5, 1.5, 1.0) and sim.data.scales["sphere_hole"] == (1.5, 1.5, 1.0)
    sim.input("hole_scale", "press", 1.0)
    sim.step()
    assert sim.data.scales == {}, "back at scene size: no override left"
