"""Scenario 5 (thesis §4.1.5): friction by the proxy's friction cone, sphere temperatures,
and the refusal of a device that shows neither."""

import pytest

from devices.capability import check
from server.core.cues import Friction, Temperature
from devices.profiles import FERROVIBE, FINGERTAC
from server.core.scenario import ParamError, Trial
from scenarios.friction_temperature import FrictionTemperature
from scenarios.registry import create
from scenarios.stiffness import SPACING
from server.loop.simulation import Simulation


def test_sticking_then_sliding_switches_mu_s_to_mu_d():
    sim = Simulation(FrictionTemperature(static_friction=0.6, dynamic_friction=0.3))
    sim.set_hip((1.0, 0.0, 0.02))  # front half of the plane, 4 cm into the proxy radius
    pressed = [sim.step() for _ in range(30)][-1]
    assert pressed.output.cues == (Friction(0.6),) and pressed.output.values["sticking"] is True
    # pull sideways far beyond the friction cone (|f_t| > mu_s |f_n|): the proxy slides, lagging
    seen = []
    for i in range(200):
        sim.set_hip((1.0, 0.005 * i, 0.02))
        seen.append(sim.step())
    assert Friction(0.3) in {c for r in seen for c in r.output.cues}
    assert seen[-1].proxy[1] < seen[-1].hip[1], "a sliding proxy lags behind the HIP"


@pytest.mark.parametrize("y, celsius", [(-SPACING, 20.0), (0.0, 32.0), (SPACING, 40.0)])
def test_touching_a_sphere_gives_its_temperature(y, celsius):
    sim = Simulation(FrictionTemperature())
    sim.set_hip((-0.8, y, 0.84))
    last = [sim.step() for _ in range(30)][-1]
    assert last.output.cues == (Temperature(celsius),)


def test_trial_sets_the_middle_temperature():
    sim = Simulation(FrictionTemperature())
    sim.set_trial(Trial.parse(FrictionTemperature.TRIAL_PARAMS, "main", {"middle_c": 26.0}))
    sim.set_hip((-0.8, 0.0, 0.84))
    last = [sim.step() for _ in range(30)][-1]
    assert last.output.cues == (Temperature(26.0),) and "how warm" in last.output.hud


def test_devices_without_friction_or_temperature_are_refused_with_reasons():
    report = check(FrictionTemperature.id, FrictionTemperature.REQUIRES, {"tac": FINGERTAC, "ferro": FERROVIBE})
    assert not report.ok and report.usable == ()
    assert "needs a device that shows friction or temperature" in report.message
    assert "tac (fingertac) cannot show the temperature cue" in report.message


def test_mu_d_above_mu_s_is_refused():
    with pytest.raises(ParamError, match="must not exceed"):
        create("friction-temperature", static_friction=0.2, dynamic_friction=0.5)
