"""Scenario 1 (spec.md Algorithm 1): angles and FerroVibe tilt directions."""

import math

import pytest

from devices.cues import Tilt
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
