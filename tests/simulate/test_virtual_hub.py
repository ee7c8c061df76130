"""The virtual hub drives the loop's own tick: a failing scenario turns the virtual device off
(fail-safe) as in `viestac serve`, and requests are checked by the hub's scenario control."""

import pytest

from devices.profiles import profile_by_model
from scenarios.contact_angle import PROXY_RADIUS, RADIUS
from server.core.scenario import ParamError
from server.simulate.virtual_device import VirtualDevice
from server.simulate.virtual_hub import VirtualHub
from tests.ipc import sent

DOME_TOP = (0.0, 0.0, RADIUS + PROXY_RADIUS - 0.003)


def rig():
    device = VirtualDevice("ferrovibe", profile_by_model("ferrovibe"))
    hub = VirtualHub({"ferrovibe": device})
    heard = []
    hub.listeners.append(lambda record: heard.append(sent(record)))  # as on the socket
    return hub, device, heard


def test_a_failing_scenario_turns_the_device_off_and_the_next_good_tick_turns_it_on_again():
    hub, device, heard = rig()
    hub.set_hip(DOME_TOP)
    hub.advance_s(0.1)
    assert device.feel.tilt()[1] == 100, "pressing the dome tilts the magnet"

    def bug(ctx):
        raise RuntimeError("scenario bug")

    hub.core.sim.scenario.step = bug
    heard.clear()
    tick = hub.tick
    hub.advance_s(0.1)
    assert hub.tick == tick + 100, "the ticks go on"
    assert device.feel.tilt()[1] == 0, "every actuator off"
    assert [r for r in heard if r[0] == "fail_safe"] == [["fail_safe"]]
    assert [r[1] for r in heard if r[0] == "log"] == ["error"] * 10 and "scenario bug" in hub.last_error
    assert not any(r[0] == "state" for r in heard), "a failed tick publishes no state"
    del hub.core.sim.scenario.step  # the class's step again
    hub.advance_s(0.1)
    assert device.feel.tilt()[1] == 100, "the next good tick sends its cue again"


def test_commands_are_checked_as_the_hub_checks_them():
    hub, _, heard = rig()
    with pytest.raises(ParamError, match="needs a value"):
        hub.command("tap_angle")
    with pytest.raises(ParamError, match="must be in"):
        hub.command("tap_angle", value=120)
    hub.command("tap_angle", value=30)
    heard.clear()
    hub.advance_s(0.05)
    events = [e for r in heard if r[0] == "state" for e in r[1]["events"]]
    assert [(e["name"], e.get("key"), e.get("value")) for e in events if e["name"] == "input"] == \
        [("input", "tap_angle", 30.0)], "only the command that passed reached the loop"
