"""The device feed thread: the loop's cue records off a real SEQPACKET channel to the devices, each
checked first; bad records are counted and the feed goes on."""

import threading
import time

import msgpack
import pytest

from server.core.cues import Tilt
from devices.feed import DeviceFeed
from server import ipc
from server.ipc.records import CUES, Alive, Cues, Stop


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
    for record in (Cues(1, now, [TILT]), Cues(2, now, []), Cues(3, now, [{"kind": "nonsense"}]),
                   ["state", {}], Cues(4, now, [TILT])):
        if isinstance(record, list):  # not a record of the cue channel
            assert loop_end.send(msgpack.packb(record))
        else:
            assert ipc.send_record(loop_end, record)
    loop_end.sendall(b"\xc1")  # not msgpack at all
    assert ipc.send_record(loop_end, Cues(5, time.monotonic_ns(), []))
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
            feed.handle(CUES.decode(bad))
    with pytest.raises(ValueError):
        feed.handle(Stop())
    assert manager.submitted == []
    feed.handle(ipc.unpack(msgpack.packb(["cues", 7, 0, [TILT]]), CUES))
    assert manager.submitted == [(Tilt(90.0, 100.0),)] and feed.last_tick == 7




def test_after_stop_no_record_reaches_the_devices():
    manager = FakeManager()
    feed = DeviceFeed(manager)
    feed.stopped = True  # the host is stopping: everything stays off
    feed.handle(Cues(1, 0, [TILT]))
    assert manager.submitted == []


def test_the_feed_asks_the_devices_to_write_at_once():
    manager = FakeManager()
    DeviceFeed(manager).handle(Cues(1, 0, [TILT]))
    assert manager.write_now is True


# ---- fail safe: the quiet rule (sans-I/O, explicit times in ns) -----------------------------------

MS = 1_000_000


def test_a_quiet_cue_channel_turns_every_actuator_off_and_the_next_record_puts_the_cues_back():
    manager = FakeManager()
    feed = DeviceFeed(manager, quiet_ms=30)
    assert feed.check(0) is None, "no record yet: the devices start off, nothing to wait for"
    feed.handle(Cues(1, 0, [TILT]), 1000 * MS)
    assert feed.check(1010 * MS) == 1030 * MS
    feed.handle(Alive(11, 0), 1020 * MS)  # the loop's heartbeat restarts the timer
    assert feed.check(1049 * MS) == 1050 * MS and manager.submitted == [(Tilt(90.0, 100.0),)]
    assert feed.check(1050 * MS) is None
    assert manager.submitted[-1] == () and manager.write_now is True
    assert feed.check(2000 * MS) is None and len(manager.submitted) == 2, "off once, not again and again"
    info = feed.info()
    assert (info["quiet"], info["quiet_offs"], info["alive"], info["records"]) == (True, 1, 1, 1)
    feed.handle(Alive(2000, 0), 2001 * MS)  # records resume: the last cue set is shown again
    assert manager.submitted[-1] == (Tilt(90.0, 100.0),) and not feed.info()["quiet"]
    assert feed.check(2002 * MS) == 2031 * MS
    assert feed.check(2031 * MS) is None and feed.info()["quiet_offs"] == 2


def test_a_restarted_loop_s_own_cues_win_over_the_last_set():
    manager = FakeManager()
    feed = DeviceFeed(manager, quiet_ms=30)
    feed.handle(Cues(1, 0, [TILT]), 0)
    feed.check(40 * MS)
    feed.handle(Cues(0, 0, []), 500 * MS)  # the new loop's first tick
    assert manager.submitted == [(Tilt(90.0, 100.0),), (), ()]
    feed.handle(Alive(10, 0), 510 * MS)
    assert manager.submitted[-1] == (), "alive does not bring back a cue the loop has since dropped"


def test_after_stop_the_quiet_rule_sends_nothing_and_bad_alive_records_are_refused():
    manager = FakeManager()
    feed = DeviceFeed(manager, quiet_ms=30)
    for bad in (["alive", 1], ["alive", "x", 0], ["alive", 1, None]):
        with pytest.raises(ValueError):
            feed.handle(CUES.decode(bad), 0)
    feed.handle(Cues(1, 0, [TILT]), 0)
    feed.stopped = True
    assert feed.check(100 * MS) is None and manager.submitted == [(Tilt(90.0, 100.0),)]
    with pytest.raises(ValueError):
        DeviceFeed(manager, quiet_ms=10)  # not above the loop's heartbeat: it would go quiet between beats


def test_the_feed_thread_turns_everything_off_when_the_loop_stops_sending():
    manager = FakeManager()
    feed = DeviceFeed(manager, quiet_ms=30)
    closed = threading.Event()
    feed.on_closed = closed.set
    feed_end, loop_end = ipc.channel_pair()
    feed.attach(feed_end)
    assert ipc.send_record(loop_end, Cues(1, time.monotonic_ns(), [TILT]))
    deadline = time.monotonic() + 2
    while not feed.info()["quiet_offs"] and time.monotonic() < deadline:
        time.sleep(0.002)
    assert manager.submitted == [(Tilt(90.0, 100.0),), ()], "off while the channel stays open but quiet"
    assert ipc.send_record(loop_end, Alive(2, time.monotonic_ns()))
    while len(manager.submitted) < 3 and time.monotonic() < deadline:
        time.sleep(0.002)
    assert manager.submitted[2] == (Tilt(90.0, 100.0),)
    loop_end.close()
    assert closed.wait(2), "a broken cue channel is reported (the host turns everything off)"
