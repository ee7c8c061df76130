"""Scenario 8 (thesis §4.2.4): path geometry, the deviation → cue rules, a scripted run whose
metrics equal those computed from the script, no short cuts, the moving-target variant."""

import math

import numpy as np
import pytest

from server.core.cues import PulseTrain
from server.core.scenario import ParamError, Trial
from scenarios.hot_wire import END_RADIUS, HotWire
from scenarios.registry import create
from scenarios.wire_path import Path, make_path, parse_points
from server.loop.simulation import Simulation
from tests.scenarios.driving import drive as run, finished, metrics_of


def make(**params):
    sim = Simulation(create("hot-wire-v1", **params))
    return sim, sim.scenario


def along(path: Path, a: float, b: float, n: int, offset=(0.0, 0.0, 0.0)):
    """n points from arc a to arc b on the path (the last one at b), shifted by `offset`."""
    return [tuple(c + o for c, o in zip(path.point_at(a + (b - a) * k / n), offset)) for k in range(1, n + 1)]


# -- geometry -------------------------------------------------------------------------------------

def test_projection_on_segments():
    path = Path([(0, 0, 0), (0, 2, 0), (1, 2, 0)])
    assert path.length == pytest.approx(3.0)
    p = path.project((0.3, 1.0, 0.4))
    assert p.distance == pytest.approx(0.5) and p.arc == pytest.approx(1.0) and p.point == pytest.approx((0, 1, 0))
    corner = path.project((-0.3, 2.4, 0.0))  # beyond the corner: nearest is the corner itself
    assert corner.point == pytest.approx((0, 2, 0)) and corner.distance == pytest.approx(0.5)
    assert path.project((0.5, 2.0, 0.0)).arc == pytest.approx(2.5)
    assert path.point_at(2.5) == pytest.approx((0.5, 2, 0)) and path.point_at(99) == pytest.approx((1, 2, 0))


@pytest.mark.parametrize("kind", ["segments", "circle", "spiral"])
def test_every_path_kind_projects_its_own_points_onto_themselves_and_fits_the_table(kind):
    path = make_path(kind, 0.5)
    rng = np.random.default_rng(1)
    for arc in rng.uniform(0, path.length, 50):
        p = path.project(path.point_at(arc))
        assert p.distance == pytest.approx(0.0, abs=1e-9) and p.arc == pytest.approx(arc, abs=1e-9)
    pts = path.points
    assert abs(pts[:, 0]).max() < 1.5 and abs(pts[:, 1]).max() < 2.0 and (pts[:, 2] == 0.5).all()
    assert math.dist(path.start, path.end) > 2 * END_RADIUS, "start and target are apart"


def test_circle_and_spiral_have_their_radii():
    circle = make_path("circle", 0.5)
    r = np.hypot(circle.points[:, 0], circle.points[:, 1])
    assert r == pytest.approx(1.0)
    assert circle.project((0.0, 0.0, 0.5)).distance == pytest.approx(1.0, abs=0.01)  # centre: a radius from it
    spiral = make_path("spiral", 0.5)
    rs = np.hypot(spiral.points[:, 0], spiral.points[:, 1])
    assert rs[0] == pytest.approx(1.2) and rs[-1] == pytest.approx(0.25) and (np.diff(rs) < 0).all()


def test_custom_points_and_their_errors():
    assert parse_points("0 0 0.5; 1, 1, 0.5") == [(0, 0, 0.5), (1, 1, 0.5)]
    with pytest.raises(ValueError, match="point 2 .* needs 3 coordinates"):
        parse_points("0 0 0; 1 1")
    with pytest.raises(ValueError, match="point 1 .* is not three numbers"):
        parse_points("a b c")
    with pytest.raises(ValueError, match="repeats the one before"):
        Path([(0, 0, 0), (0, 0, 0)])
    with pytest.raises(ParamError, match="points only apply to path 'segments'"):
        create("hot-wire-v1", path="circle", points="0 0 0; 1 0 0")
    with pytest.raises(ParamError, match="needs 3 coordinates"):
        create("hot-wire-v1", points="0 0 0.5; 1 0")
    with pytest.raises(ParamError, match="max_distance .* must exceed threshold"):
        create("hot-wire-v1", threshold=0.3, max_distance=0.2)
    sc = create("hot-wire-v1", points="0 -1 0.4; 0 1 0.4")
    assert sc.path.length == pytest.approx(2.0)


def test_the_wire_is_a_drawn_mesh_along_the_path():
    sim, sc = make(path="circle")
    wire = sim.scene.object("wire")
    assert wire.shape.type == "mesh" and not wire.haptic
    v = np.array(wire.shape.vertices)
    assert np.hypot(v[:, 0], v[:, 1]) == pytest.approx(1.0, abs=0.02) and v[:, 2] == pytest.approx(0.5, abs=0.02)
    assert sim.scene.camera.projection == "perspective"


# -- cue rules ------------------------------------------------------------------------------------

def test_deviation_drives_the_cue():
    sim, sc = make(threshold=0.06, max_distance=0.3)
    path = sc.path
    run(sim, [path.start] * 2)
    assert sc.phase == "tracing"
    on = path.point_at(0.5)
    cues = {}
    for dz in (0.0, 0.05, 0.07, 0.18, 0.29, 0.31):
        cues[dz] = run(sim, [(on[0], on[1], on[2] + dz)])[-1].output.cues
    assert cues[0.0] == () and cues[0.05] == (), "within the threshold: no cue"
    assert cues[0.31] == (), "beyond the maximum distance the cue stops"
    weak, mid, strong = cues[0.07][0], cues[0.18][0], cues[0.29][0]
    assert all(isinstance(c, PulseTrain) for c in (weak, mid, strong))
    assert weak.intensity_pct < mid.intensity_pct < strong.intensity_pct, "intensity rises with the deviation"
    assert weak.t_off_ms > mid.t_off_ms > strong.t_off_ms, "and so does the pulse rate"
    assert mid.intensity_pct == pytest.approx(30 + 70 * 0.5) and mid.t_off_ms == pytest.approx(250.0)


# -- a scripted run -------------------------------------------------------------------------------

def test_scripted_run_metrics_equal_those_of_the_script():
    sim, sc = make(path="segments", threshold=0.06, max_distance=0.3)
    path = sc.path
    approach = [(path.start[0], path.start[1], 1.0), path.start]
    off = (0.0, 0.0, 0.1)   # 0.1 above the wire: outside the 0.06 threshold
    script = (along(path, 0.0, 1.0, 500) + along(path, 1.0, 1.6, 300, off) + along(path, 1.6, path.length, 2000))
    results = run(sim, approach + script)
    events = {e["name"]: e for e in sim.data.events}
    assert set(events) >= {"start", "trial_done"} and sc.phase == "done"
    done = events["trial_done"]
    start_tick = events["start"]["tick"]
    hips = [r.hip for r in results[start_tick:done["tick"] + 1]]
    assert done["path_length"] == pytest.approx(sum(math.dist(a, b) for a, b in zip(hips, hips[1:])), abs=1e-6)
    deviations = [path.project(h).distance for h in hips]
    outside_ticks = sum(d > 0.06 for d in deviations[1:])  # each tick outside adds its dt
    assert done["time_outside_s"] == pytest.approx(outside_ticks / 1000, abs=1e-9)
    assert 0.29 <= done["time_outside_s"] <= 0.301, "the 300 shifted ticks, give or take a corner"
    assert done["deviation_max"] == pytest.approx(max(deviations), abs=1e-9)
    assert done["deviation_mean"] == pytest.approx(sum(deviations) / len(deviations), abs=1e-9)
    assert finished(results) == [(done["tick"], metrics_of(done))], "the run's end is the step's `finished` too"
    assert done["completion_s"] == pytest.approx((done["tick"] - start_tick) / 1000, abs=1e-9)
    assert done["progress"] >= (path.length - END_RADIUS) / path.length
    assert results[-1].output.values["time_outside_s"] == done["time_outside_s"], "exposed in state"


def test_no_short_cut_to_the_target():
    sim, sc = make(path="circle")
    path = sc.path
    run(sim, [path.start] * 2 + along(path, 0.0, 0.5, 50))
    run(sim, [path.end] * 50)  # the circle's open end lies 0.52 from its start: jump there
    assert sc.phase == "tracing", "progress only counts when the HIP moves along the wire"
    run(sim, along(path, 0.5, path.length, 3000))
    assert sc.phase == "done"


def test_restart_key_and_operator_threshold():
    sim, sc = make()
    away = (sc.path.start[0], sc.path.start[1], 1.5)
    run(sim, [sc.path.start] * 2 + [away] * 100)
    assert sc.phase == "tracing" and sc.time_outside > 0
    sim.input("r", "down")
    sim.step()
    assert sc.phase == "start" and sim.data.events[-1]["name"] == "restart" and sc.time_outside == 0
    sim.input("threshold", "press", 0.12)
    sim.step()
    assert sc.allowed == 0.12 and sim.data.events[-1] == {**sim.data.events[-1], "name": "threshold", "threshold": 0.12}
    sim.input("threshold", "press", 0.3)  # not below max_distance: refused, kept
    sim.step()
    assert sc.allowed == 0.12 and sim.data.events[-1]["name"] == "refused"
    sim.set_trial(Trial.parse(HotWire.TRIAL_PARAMS, "main", {"threshold": 0.02}))
    sim.step()
    assert sc.allowed == 0.02 and sc.phase == "start"
    assert sim.step().output.hud == "Trial 1: Touch the start"


# -- moving target --------------------------------------------------------------------------------

def test_moving_target_paces_the_run():
    speed = 0.5
    sim, sc = make(path="segments", target_speed=speed, threshold=0.06, max_distance=0.3)
    path = sc.path
    run(sim, [path.start] * 2)
    assert sim.data.visibility["pacer"] is True
    start_tick = next(e["tick"] for e in sim.data.events if e["name"] == "start")
    last = run(sim, [path.start] * 400)[-1]  # 0.4 s at the start: the pacer is 0.2 ahead
    assert sim.data.moved["pacer"].pos == pytest.approx(path.point_at(0.2), abs=1e-3)
    assert last.output.values["lag"] == pytest.approx(0.2, abs=1e-3) and last.output.values["deviation"] == 0
    assert isinstance(last.output.cues[0], PulseTrain), "on the wire but behind the target: the lag is the cue"
    # follow 0.4 s behind the pacer to the end
    behind = [path.point_at(speed * ((sim.data.tick + k - start_tick) / 1000 - 0.4)) for k in range(1, 30000)]
    behind = behind[:next(k for k, p in enumerate(behind) if p == path.end) + 1]
    results = run(sim, behind)
    assert sc.phase == "done" and sim.data.visibility["pacer"] is False
    done = next(e for e in sim.data.events if e["name"] == "trial_done")
    assert 0.15 < done["lag_mean"] <= 0.2 + 1e-3, "0.2 along the path, a chord at the corners"
    assert results[-1].output.values["phase"] == "done"


def test_moving_target_run_ends_only_when_the_target_arrives():
    speed = 0.5
    sim, sc = make(path="segments", target_speed=speed)
    path = sc.path
    run(sim, [path.start] * 2)
    ahead = along(path, 0.0, path.length, int(path.length / (2 * speed) * 1000))  # twice the pacer's speed
    run(sim, ahead)
    assert sc.phase == "tracing", "at the target before the pacer: not done"
    wait = int(path.length / (2 * speed) * 1000) + 5
    run(sim, [path.end] * wait)
    assert sc.phase == "done"
    done = next(e for e in sim.data.events if e["name"] == "trial_done")
    assert done["completion_s"] == pytest.approx(path.length / speed, abs=2e-3)
