"""Device reports from the device host process to the hub: the loop learns the refusals no device
shows (also after a restart), listeners (the recorder) see each change once."""

import asyncio

from devices.encoder import Refusal
from devices.manager import unshown_refusals
from server.hub.hub import Hub
from server.ipc.records import DeviceReport, Hello
from tests.ipc import sent


def test_reports_reach_the_loop_once_per_change_and_a_restarted_loop_learns_them_again():
    async def go():
        to_loop, heard = [], []
        hub = Hub(server_name="test", tick_hz=1000, state_hz=60, send_to_loop=lambda record: to_loop.append(record) or True)
        hub.link.listeners.append(heard.append)
        refusing = {"refusals": ["tac refuses tilt"], "status": {"tac": "connected"}}
        for report in ({"refusals": [], "status": {"tac": "connected"}}, refusing, refusing):
            hub.link.on_device_report(report)
        reports = [r[1] for r in map(sent, to_loop) if r[0] == "devices"]
        assert [r["refusals"] for r in reports] == [[], ["tac refuses tilt"]]
        assert heard == [DeviceReport(r) for r in reports]
        to_loop.clear()
        hub.link.on_loop_record(Hello({"pid": 1, "rt": True}))  # a restarted loop learns the refusals again
        assert to_loop == [DeviceReport(refusing)]

    asyncio.run(go())


def test_only_cues_no_device_shows_reach_the_participant():
    tac = Refusal("tac", "fingertac", "tilt", "macro_roughness", "not_displayed", "tac refuses tilt")
    ferro_heat = Refusal("ferro", "ferrovibe", "temperature", "temperature", "not_displayed", "ferro refuses heat")
    tac_heat = Refusal("tac", "fingertac", "temperature", "temperature", "not_displayed", "tac refuses heat")
    # the FerroVibe shows the tilt the FingerTac refuses; neither shows a temperature
    assert unshown_refusals((tac, ferro_heat, tac_heat), 2) == ["ferro refuses heat", "tac refuses heat"]
    assert unshown_refusals((tac,), 1) == ["tac refuses tilt"]
    assert unshown_refusals((), 2) == []
