"""The hub between loop records and the device manager: cues go to the devices once per change,
a failing tick turns them off, and refusals travel back to the loop (also after a restart)."""

import asyncio

from devices.cues import Tilt
from devices.encoder import Refusal
from server.hub.hub import Hub


class FakeManager:
    def __init__(self):
        self.listeners = []
        self.submitted = []
        self.refusals = ()
        self.devices = {"tac": None}  # one device: whatever it refuses, nobody shows

    def submit(self, cues):
        self.submitted.append(cues)
        if any(isinstance(c, Tilt) for c in cues):
            self.refusals = (Refusal("tac", "fingertac", "tilt", "macro_roughness", "not_displayed", "tac refuses tilt"),)
        else:
            self.refusals = ()
        for listener in self.listeners:
            listener()
        return self.refusals

    def status(self):
        return {"tac": "connected"}


def state(frame, cues):
    return ["state", {"frame": frame, "tick": frame, "t": frame / 1000, "hip": [0, 0, 0], "proxy": [0, 0, 0],
                      "force": [0, 0, 0], "contact": bool(cues), "contacts": [], "objects": [], "cues": cues, "hud": "",
                      "values": {}, "samples": b"", "trackers": []}]


def test_cues_reach_the_devices_once_per_change_and_refusals_reach_the_loop():
    async def go():
        hub = Hub(server_name="test", tick_hz=1000, state_hz=60)
        to_loop = []
        hub.send_to_loop = lambda record: to_loop.append(record) or True
        manager = FakeManager()
        hub.attach_devices(manager)
        tilt = {"kind": "tilt", "direction_deg": 90.0, "magnitude_pct": 100.0}
        for frame, cues in enumerate([[], [tilt], [tilt], [tilt], []]):
            hub.on_loop_record(state(frame, cues))
            await asyncio.sleep(0)  # listener callbacks are scheduled with call_soon_threadsafe
        assert manager.submitted == [(), (Tilt(90.0, 100.0),), ()]
        reports = [r[1] for r in to_loop if r[0] == "devices"]
        assert [r["refusals"] for r in reports] == [[], ["tac refuses tilt"], []]

        hub.on_loop_record(state(5, [tilt]))
        hub.on_loop_record(["fail_safe"])  # a tick failed in the loop: every actuator off
        assert manager.submitted[-2:] == [(Tilt(90.0, 100.0),), ()]
        hub.on_loop_record(state(6, [tilt]))  # the next good tick sends the cue again
        assert manager.submitted[-1] == (Tilt(90.0, 100.0),)
        await asyncio.sleep(0)
        to_loop.clear()
        hub.on_loop_record(["hello", {"pid": 1, "rt": True}])  # a restarted loop learns the refusals again
        assert to_loop == [["devices", {"refusals": ["tac refuses tilt"], "status": {"tac": "connected"}}]]

    asyncio.run(go())


def test_only_cues_no_device_shows_reach_the_participant():
    from server.hub.hub import unshown_refusals

    tac = Refusal("tac", "fingertac", "tilt", "macro_roughness", "not_displayed", "tac refuses tilt")
    ferro_heat = Refusal("ferro", "ferrovibe", "temperature", "temperature", "not_displayed", "ferro refuses heat")
    tac_heat = Refusal("tac", "fingertac", "temperature", "temperature", "not_displayed", "tac refuses heat")
    # the FerroVibe shows the tilt the FingerTac refuses; neither shows a temperature
    assert unshown_refusals((tac, ferro_heat, tac_heat), 2) == ["ferro refuses heat", "tac refuses heat"]
    assert unshown_refusals((tac,), 1) == ["tac refuses tilt"]
    assert unshown_refusals((), 2) == []
