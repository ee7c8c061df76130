"""The hub's browser device (server/hub/browser_actuators.py): a page's offer makes it connected in
health and in the device report the loop and the recorder get; each state frame carries the drive,
encoded once per cue change, keeping its onset while the pattern stays; on a rig with no other
device its refusals are the rig's."""

import asyncio

from devices.manager import DeviceConfig
from devices.profiles import profile_by_model
from server.core.cues import Texture, Tilt, Vibration, cue_to_wire
from server.hub.hub import Hub
from server.hub.session import ActuatorsOffered
from tests.ipc import sent

BROWSER = DeviceConfig("browser", profile_by_model("browser"), None)


def view(tick: int, *cues) -> dict:
    return {"tick": tick, "cues": [cue_to_wire(c) for c in cues]}


def hub_with_browser(to_loop: list) -> Hub:
    hub = Hub(server_name="test", tick_hz=1000, state_hz=60, send_to_loop=lambda record: to_loop.append(record) or True)
    hub.actuators.configure(BROWSER)
    hub.health_feed.device_profiles = hub.actuators.profiles()
    return hub


def test_a_page_that_offers_an_actuator_connects_the_device_and_leaving_disconnects_it():
    async def go():
        to_loop = []
        hub = hub_with_browser(to_loop)
        hub.link.on_device_report({"refusals": [], "status": {}})  # the device host: no device of its own
        assert hub.health_feed.device_statuses == {"browser": "disconnected"}
        hub.forward(None, [ActuatorsOffered(3, (), "tracked hands have no actuator")])
        assert hub.health_feed.device_statuses == {"browser": "disconnected"}
        assert "client 3: tracked hands have no actuator" in hub.actuators.snapshot()["last_error"]
        hub.forward(None, [ActuatorsOffered(4, (("gamepad", "none"),), "")])
        assert hub.health_feed.device_statuses == {"browser": "connected"}
        assert [sent(r)[1]["status"] for r in to_loop if sent(r)[0] == "devices"][-1] == {"browser": "connected"}
        hub.forward(None, [ActuatorsOffered(4, (), "", left=True)])
        assert hub.health_feed.device_statuses == {"browser": "disconnected"}
        assert [p["client_id"] for p in hub.actuators.snapshot()["pages"]] == [3]
        assert (hub.actuators.connects, hub.actuators.disconnects) == (1, 1)

    asyncio.run(go())


def test_the_drive_is_encoded_per_cue_change_and_keeps_its_onset_while_the_pattern_stays():
    hub = hub_with_browser([])
    actuators = hub.actuators
    assert actuators.state_field(view(10)) == [0.0, 0.0, 0.0, 0.0, 10]
    assert actuators.state_field(view(11, Tilt(90.0, 60.0))) == [0.6, 0.0, 0.0, 0.0, 11]
    assert actuators.state_field(view(12, Tilt(180.0, 60.0))) == [0.6, 0.0, 0.0, 0.0, 11], "same pattern: same onset"
    assert actuators.state_field(view(13, Vibration(30.0, duration_ms=250.0))) == [0.3, 0.0, 0.0, 250.0, 13]
    assert actuators.state_field(view(14)) == [0.0, 0.0, 0.0, 0.0, 14]
    assert Hub(server_name="t", tick_hz=1000, state_hz=60).actuators.state_field(view(1, Tilt(0.0, 50.0))) is None


def test_on_a_rig_without_other_devices_its_refusals_reach_the_loop():
    async def go():
        to_loop = []
        hub = hub_with_browser(to_loop)
        hub.link.on_device_report({"refusals": [], "status": {}})
        hub.actuators.state_field(view(5, Texture(period_us=4000.0)))  # a new refusal: the loop hears it at once
        report = [sent(r)[1] for r in to_loop if sent(r)[0] == "devices"][-1]
        (reason,) = report["refusals"]
        assert reason.startswith("browser (browser) cannot show the texture cue")
        hub.link.on_device_report({"refusals": ["tac refuses tilt"], "status": {"tac": "connected"}})
        report = [sent(r)[1] for r in to_loop if sent(r)[0] == "devices"][-1]
        assert report == {"refusals": ["tac refuses tilt"], "status": {"tac": "connected", "browser": "disconnected"}}

    asyncio.run(go())
