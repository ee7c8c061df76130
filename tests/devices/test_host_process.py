"""The device host process's own fail-safe: a broken cue channel or control channel turns every
actuator off first (devices/host_process.py), with a stand-in manager so the order is visible."""

import socket
import threading
import time

from devices.host_process import DeviceHost
from server import ipc

TILT = {"kind": "tilt", "direction_deg": 90.0, "magnitude_pct": 100.0}


class RecordingManager:
    def __init__(self):
        self.calls = []
        self.listeners = []
        self.devices = {}

    def start(self):
        self.calls.append("start")

    def stop(self):
        self.calls.append("stop")

    def submit(self, cues, write_now=False):
        self.calls.append(("submit", tuple(c.kind for c in cues)))
        return ()

    def report(self):
        return {"refusals": [], "status": {}}


def wait_for(predicate, timeout_s=2.0):
    deadline = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.005)


def test_a_broken_cue_channel_turns_everything_off_and_keeps_it_off():
    manager = RecordingManager()
    control, hub_end = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    feed_end, loop_end = ipc.channel_pair()
    host = DeviceHost(manager, control, cue_quiet_ms=60_000)
    runner = threading.Thread(target=host.run, args=(feed_end,), daemon=True)
    runner.start()
    assert ipc.send_record(loop_end, ["cues", 1, time.monotonic_ns(), [TILT]])
    wait_for(lambda: ("submit", ("tilt",)) in manager.calls)
    loop_end.close()  # the cue channel breaks: nobody drives the devices any more
    wait_for(lambda: manager.calls[-1] == ("submit", ()))
    assert host.feed.stopped, "later records must not turn anything back on"
    hub_end.close()  # the hub goes away: stop, everything off before the ports close
    runner.join(2)
    assert not runner.is_alive()
    assert manager.calls[-2:] == [("submit", ()), "stop"]
