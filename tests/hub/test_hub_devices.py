"""Cues from the loop to the devices, and device reports back: the device feed thread takes the
loop's cue records off a real SEQPACKET channel and hands them to the manager (past the hub's
event loop); refusals travel back to the loop through the hub (also after a restart)."""

import asyncio
import threading
import time

import msgpack
import pytest

from devices.cues import Tilt
from devices.encoder import Refusal
from server.hub.device_feed import DeviceFeed
from server.hub.hub import Hub
from server.loop import ipc


class FakeManager:
    def __init__(self):
        self.listeners = []
        self.submitted = []
        self.refusals = ()
        self.devices = {"tac": None}  # one device: whatever it refuses, nobody shows
        self.threads = set()

    def submit(self, cues):
        self.threads.add(threading.current_thread().name)
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


TILT = {"kind": "tilt", "direction_deg": 90.0, "magnitude_pct": 100.0}


def test_the_feed_thread_hands_every_cue_record_to_the_devices_and_survives_bad_ones():
    manager = FakeManager()
    feed = DeviceFeed(manager)
    feed_end, loop_end = ipc.channel_pair()
    feed.attach(feed_end)
    now = time.monotonic_ns()
    for record in (["cues", 1, now, [TILT]], ["cues", 2, now, []], ["cues", 3, now, [{"kind": "nonsense"}]],
                   ["state", {}], ["cues", 4, now, [TILT]]):
        assert ipc.send_record(loop_end, record)
    loop_end.sendall(b"\xc1")  # not msgpack at all
    assert ipc.send_record(loop_end, ["cues", 5, time.monotonic_ns(), []])
    loop_end.close()  # the loop process went away: the thread ends
    feed.join(2.0)
    assert not any(t.is_alive() for t in feed._threads)
    assert manager.submitted == [(Tilt(90.0, 100.0),), (), (Tilt(90.0, 100.0),), ()]
    assert manager.threads == {"device-feed"}, "submitted on the feed thread, not the caller's"
    info = feed.info()
    assert {k: info[k] for k in ("records", "bad_records", "last_tick")} == {"records": 4, "bad_records": 3, "last_tick": 5}
    hop = info["delay"]
    assert 0 < hop["received"]["p50_us"] <= hop["handed_over"]["p50_us"] <= hop["handed_over"]["max_us"]
    assert hop["handed_over"]["max_us"] < (time.monotonic_ns() - now) / 1000


def test_a_feed_record_is_checked_before_it_reaches_the_devices():
    manager = FakeManager()
    feed = DeviceFeed(manager)
    for bad in (["cues", 1, 0], ["cues", 1, 0, "tilt"], "cues", ["cues", 1, None, []],
                ["cues", 1, 0, [{"kind": "tilt", "spin": 3}]]):
        with pytest.raises(ValueError):
            feed.handle(bad)
    assert manager.submitted == []
    feed.handle(msgpack.unpackb(msgpack.packb(["cues", 7, 0, [TILT]]), raw=False))
    assert manager.submitted == [(Tilt(90.0, 100.0),)] and feed.last_tick == 7


def test_refusals_reach_the_loop_and_a_restarted_loop_learns_them_again():
    async def go():
        hub = Hub(server_name="test", tick_hz=1000, state_hz=60)
        to_loop = []
        hub.send_to_loop = lambda record: to_loop.append(record) or True
        manager = FakeManager()
        hub.attach_devices(manager)
        feed = DeviceFeed(manager)
        for tick, cues in enumerate([[TILT], []]):
            feed.handle(["cues", tick, 0, cues])
            await asyncio.sleep(0)  # listener callbacks are scheduled with call_soon_threadsafe
        reports = [r[1] for r in to_loop if r[0] == "devices"]
        assert [r["refusals"] for r in reports] == [[], ["tac refuses tilt"], []]
        feed.handle(["cues", 2, 0, [TILT]])
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
