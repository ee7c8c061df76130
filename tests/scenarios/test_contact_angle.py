"""Scenario 1 (thesis Algorithm 1): angles and FerroVibe tilt directions."""

import math

import pytest

from server.core.cues import Tilt
from scenarios.contact_angle import RADIUS, ContactAngle, contact_angle_deg
from scenarios.registry import UnknownScenario, create, resolve
from server.loop.simulation import Simulation


@pytest.mark.parametrize("hip, angle, tilt", [
    ((0.0, -RADIUS, 0.0), -90.0, 90.0),   # bottom-left
    ((0.0, 0.0, RADIUS), 0.0, 0.0),       # top
    ((0.0, RADIUS, 0.0), 90.0, 270.0),    # bottom-right
])
def test_reference_points_through_the_simulation(hip, angle, tilt):
    sim = Simulation(ContactAngle())
    sim.set_hip(hip)
    result = None
    for _ in range(5):
        result = sim.step()
    assert result.contact
    assert result.output.values["angle_deg"] == pytest.approx(angle, abs=0.5)
    (cue,) = result.output.cues
    assert isinstance(cue, Tilt) and cue.magnitude_pct == 100.0
    assert cue.direction_deg == pytest.approx(tilt, abs=0.5)


@pytest.mark.parametrize("angle", [-90, -70, -50, -30, -10, 10, 30, 50, 70, 90])
def test_study_angles_on_the_arc(angle):
    a = math.radians(angle)
    hip = (0.0, RADIUS * math.sin(a), RADIUS * math.cos(a))
    assert contact_angle_deg(hip) == pytest.approx(angle, abs=1e-9)


def test_no_cue_without_contact():
    sim = Simulation(ContactAngle())
    sim.set_hip((0.0, 0.0, 1.5))
    result = sim.step()
    assert not result.contact and result.output.cues == () and result.output.values == {}


def test_touching_only_the_ground_gives_no_angle():
    sim = Simulation(ContactAngle())
    sim.set_hip((0.0, 1.2, 0.05))  # on the ground, right of the dome
    for _ in range(5):
        result = sim.step()
    assert result.contact and result.output.cues == ()


def test_registry_resolves_versions_and_suggests():
    assert resolve("contact-angle").id == "contact-angle-v1"
    assert isinstance(create("contact-angle-v1"), ContactAngle)
    with pytest.raises(UnknownScenario, match="did you mean"):
        resolve("contact-angel")


# -- study aids: angle scale, experimenter's tap, phases --------------------------------------

from server.core.scenario import Trial  # noqa: E402
from scenarios.contact_angle import SCALE_ID, STUDY_ANGLES, point_at_angle  # noqa: E402


def _steps(sim, n):
    out = []
    for _ in range(n):
        out.append(sim.step())
    return out


@pytest.mark.parametrize("angle", [-90.0, -50.0, 0.0, 30.0, 90.0])
def test_point_at_angle_inverts_algorithm_1(angle):
    for distance in (0.3, RADIUS, 0.65):
        assert contact_angle_deg(point_at_angle(angle, distance)) == pytest.approx(angle, abs=1e-9)


@pytest.mark.parametrize("angle", STUDY_ANGLES)
def test_tap_holds_the_hip_at_the_angle_and_tilts_toward_minus_a(angle):
    sim = Simulation(ContactAngle())
    sim.set_hip((0.0, 0.0, 1.5))  # the tracker is far above the dome: the tap overrides it
    sim.input("tap_angle", "press", angle)
    results = _steps(sim, 60)
    last = results[-1]
    assert last.contact and last.output.values["angle_deg"] == pytest.approx(angle, abs=1e-6)
    (tilt,) = last.output.cues
    assert tilt.direction_deg == pytest.approx((-angle) % 360, abs=1e-6)
    assert results[0].output.events[0]["name"] == "tap"
    sim.input("release", "press")
    sim.step()
    assert not _steps(sim, 60)[-1].contact, "after release the tracker (far above) drives the HIP again"


def test_angle_scale_shows_in_training_only_and_hud_never_gives_the_angle_away():
    sim = Simulation(ContactAngle())
    assert sim.scene.overlays[0].id == SCALE_ID
    sim.input("tap_angle", "press", -30.0)
    train = _steps(sim, 40)[-1]
    assert sim.data.visibility[SCALE_ID] is True and train.output.hud == "Angle -30°"
    sim.set_trial(Trial.parse(ContactAngle.TRIAL_PARAMS, "main", {"angle_deg": 50.0}, index=2))
    main = _steps(sim, 40)[-1]
    assert sim.data.visibility[SCALE_ID] is False
    assert main.output.hud == "Trial 3: which angle do you feel?" and "50" not in main.output.hud
    assert main.output.values["angle_deg"] == pytest.approx(50.0, abs=1e-6)  # the operator still sees it
    sim.input("scale", "press", True)  # the experimenter may show it anyway
    sim.step()
    assert sim.data.visibility[SCALE_ID] is True


def test_main_trial_tap_is_released_after_the_time_limit():
    sim = Simulation(ContactAngle(), tick_hz=1000)
    sim.set_hip((0.0, 0.0, 1.5))
    sim.set_trial(Trial.parse(ContactAngle.TRIAL_PARAMS, "main", {"angle_deg": 10.0, "time_limit_s": 2.0}))
    results = _steps(sim, 2100)
    assert results[1000].contact and not results[-1].contact
    release = [e for r in results for e in r.output.events if e["name"] == "release"]
    assert release and release[0]["by"] == "time_limit"
    assert sim.data.events[-1]["name"] == "release" and sim.data.events[-1]["tick"] == pytest.approx(2000, abs=2)


def test_the_study_design_is_spec_md():
    (angles,) = ContactAngle.SUBTASKS
    assert [c["angle_deg"] for c in angles.conditions] == [-90, -70, -50, -30, -10, 10, 30, 50, 70, 90]
    assert (angles.practice_trials, angles.training_s, angles.time_limit_s) == (3, 120.0, 30.0)
