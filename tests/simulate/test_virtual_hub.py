"""The virtual hub: requests are checked by the hub's scenario control."""

import pytest

from devices.profiles import profile_by_model
from scenarios.contact_angle import PROXY_RADIUS, RADIUS
from server.core.scenario import ParamError
from server.simulate.virtual_device import VirtualDevice
from server.simulate.virtual_hub import VirtualHub

DOME_TOP = (0.0, 0.0, RADIUS + PROXY_RADIUS - 0.003)


def rig():
    device = VirtualDevice("ferrovibe", profile_by_model("ferrovibe"))
    hub = VirtualHub({"ferrovibe": device})
    heard = []
    hub.listeners.append(heard.append)
    return hub, device, heard


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
