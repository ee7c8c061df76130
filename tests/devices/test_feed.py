"""The device feed thread: the loop's cue records off a real SEQPACKET channel to the devices, each
checked first; bad records are counted and the feed goes on."""

import threading
import time

import msgpack
import pytest

from server.core.cues import Tilt
from devices.feed import DeviceFeed
from server import ipc


class FakeManager:
    def __init__(self):
        self.submitted = []
        self.threads = set()
        self.write_now = None

    def submit(self, cues, write_now=False):
        self.threads.add(threading.current_thread().name)
        self.submitted.append(cues)
        self.write_now = write_now
        return ()


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
    feed.thread.join(2.0)
    assert not feed.thread.is_alive()
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




def test_after_stop_no_record_reaches_the_devices():
    manager = FakeManager()
    feed = DeviceFeed(manager)
    feed.stopped = True  # the host is stopping: everything stays off
    feed.handle(["cues", 1, 0, [TILT]])
    assert manager.submitted == []


def test_the_feed_asks_the_devices_to_write_at_once():
    manager = FakeManager()
    DeviceFeed(manager).handle(["cues", 1, 0, [TILT]])
    assert manager.write_now is True
