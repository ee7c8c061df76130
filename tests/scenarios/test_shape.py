"""Scenario 4 (thesis Algorithm 2): every branch, through the pure rule and through touch."""

import pytest

from server.core.cues import Texture, Tilt
from server.core.scenario import Trial
from scenarios.shape import SHAPES, ShapeScenario, algorithm2
from server.loop.simulation import Simulation

C = (0.0, 0.3, 0.0)  # an origin off the axis, so c.y matters


@pytest.mark.parametrize("point, expected", [
    ((0.0, C[1] - 0.5, 0.4), (90.0, 100.0)),     # HIP.y <= c.y - 0.5: left face
    ((0.0, C[1] - 0.51, 1.2), (90.0, 100.0)),    # left wins over top (checked first)
    ((0.0, C[1] + 0.5, 0.4), (270.0, 100.0)),    # HIP.y >= c.y + 0.5: right face
    ((0.0, C[1] + 0.1, 1.0), (0.0, 100.0)),      # HIP.z >= c.z + 1: top face
    ((0.0, C[1] + 0.1, 0.99), None),             # inside: do nothing
])
def test_cube_branches(point, expected):
    assert algorithm2("cube", point, C) == expected


@pytest.mark.parametrize("point, expected", [
    ((0.0, C[1], 0.3), (90.0, 60.0)),            # HIP.y <= c.y (equal: left branch)
    ((0.0, C[1] - 0.2, 0.3), (90.0, 60.0)),
    ((0.0, C[1] + 0.01, 0.3), (270.0, 60.0)),    # HIP.y >= c.y
])
def test_cone_branches(point, expected):
    assert algorithm2("cone", point, C) == expected


@pytest.mark.parametrize("angle_point, direction", [
    ((0.0, C[1] - 0.5, 0.0), 90.0),   # Algorithm 1 around the centre: left side -90 → 90°
    ((0.0, C[1], 0.5), 0.0),          # top → 0°
    ((0.0, C[1] + 0.5, 0.0), 270.0),  # right side +90 → 270°
])
def test_sphere_follows_algorithm_1_at_full_magnitude(angle_point, direction):
    d, m = algorithm2("sphere", angle_point, C)
    assert d == pytest.approx(direction, abs=1e-9) and m == 100.0


def test_unknown_shape_is_an_error():
    with pytest.raises(ValueError, match="unknown shape"):
        algorithm2("pyramid", (0, 0, 0), C)


def _present(shape, hidden=True, **params):
    sim = Simulation(ShapeScenario(**params))
    sim.set_trial(Trial.parse(ShapeScenario.TRIAL_PARAMS, "main", {"shape": shape, "hidden": hidden}))
    sim.step()
    return sim


def _touch(sim, hip, n=40, start=(0.0, 0.0, 2.0)):
    """Move the HIP in a straight line from `start` to `hip` over 50 ticks, then hold it."""
    for i in range(51):
        f = i / 50
        sim.set_hip(tuple(a + f * (b - a) for a, b in zip(start, hip)))
        sim.step()
    return [sim.step() for _ in range(n)][-1]


@pytest.mark.parametrize("start, hip, direction", [
    ((0.0, -1.0, 0.5), (0.0, -0.54, 0.5), 90.0),   # pressing the left face: 2 cm into the proxy radius
    ((0.0, 1.0, 0.5), (0.0, 0.54, 0.5), 270.0),
    ((0.0, 0.1, 2.0), (0.0, 0.1, 1.04), 0.0),      # the top face
])
def test_touching_the_presented_cube(start, hip, direction):
    last = _touch(_present("cube"), hip, start=start)
    assert last.output.values["touching"] == "cube"
    assert last.output.cues == (Tilt(direction, 100.0),)


def test_deep_press_on_the_cube_side_gives_nothing_with_the_hip_but_the_side_with_the_proxy():
    hip, side = (0.0, -0.3, 0.5), (0.0, -1.0, 0.5)  # pushed 0.26 deep through the left face: HIP.y > c.y - 0.5
    assert _touch(_present("cube"), hip, start=side).output.cues == ()
    assert _touch(_present("cube", probe="proxy"), hip, start=side).output.cues == (Tilt(90.0, 100.0),)


@pytest.mark.parametrize("y, direction", [(-0.2, 90.0), (0.2, 270.0)])
def test_touching_the_presented_cone(y, direction):
    last = _touch(_present("cone"), (0.0, y, 0.55), start=(0.0, 4 * y, 0.55))
    assert last.output.values["touching"] == "cone" and last.output.cues == (Tilt(direction, 60.0),)


def test_trial_presents_one_shape_at_the_centre_and_hides_it():
    sim = _present("sphere")
    assert sim.data.moved["sphere"].pos == (0.0, 0.0, 0.5)
    assert {s: sim.data.visibility[s] for s in SHAPES} == {"cube": False, "sphere": False, "cone": False}
    assert sim.data.untouchable == {"cube", "cone"}
    last = _touch(sim, (0.0, 0.0, 1.04))
    assert last.output.cues == (Tilt(0.0, 100.0),) and "which shape" in last.output.hud
    sim.set_trial(None)  # back to the gallery
    sim.step()
    assert sim.data.untouchable == set() and all(sim.data.visibility[s] for s in SHAPES)
    assert sim.data.moved["cube"].pos == (0.0, -1.5, 0.5)


def test_texture_overlay_lowers_the_tilt_magnitude():
    last = _touch(_present("cube", texture_period_us=4000.0), (0.0, 0.1, 1.04))
    assert last.output.cues == (Tilt(0.0, 70.0), Texture(4000.0))
