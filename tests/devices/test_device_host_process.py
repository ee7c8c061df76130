"""The device host process's own fail-safe: a broken cue channel or control channel turns every
actuator off first (devices/device_host_process.py), with a stand-in manager so the order is visible."""

import socket
import threading
import time

import msgpack

from devices.device_host_process import DeviceHostProcess
from server import ipc
from server.ipc.records import Cues

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
    host = DeviceHostProcess(manager, control, cue_quiet_ms=60_000)
    runner = threading.Thread(target=host.run, args=(feed_end,), daemon=True)
    runner.start()
    assert ipc.send_record(loop_end, Cues(1, time.monotonic_ns(), [TILT]))
    wait_for(lambda: ("submit", ("tilt",)) in manager.calls)
    loop_end.close()  # the cue channel breaks: nobody drives the devices any more
    wait_for(lambda: manager.calls[-1] == ("submit", ()))
    assert host.feed.stopped, "later records must not turn anything back on"
    hub_end.close()  # the hub goes away: stop, everything off before the ports close
    runner.join(2)
    assert not runner.is_alive()
    assert manager.calls[-2:] == [("submit", ()), "stop"]


class RacingManager(RecordingManager):
    """Two device threads announce changes at once: the first reads the statuses, then stalls
    (`hold`) while the second device connects and announces it."""

    def __init__(self):
        super().__init__()
        self.status = {"fingertac": "connected", "ferrovibe": "handshaking"}
        self.hold = threading.Event()
        self.read = threading.Event()
        self.stall_next = True

    def report(self):
        report = {"refusals": [], "status": dict(self.status)}
        if self.stall_next:
            self.stall_next = False
            self.read.set()
            self.hold.wait(2)
        return report


def test_the_hub_is_left_with_the_newest_report_when_two_devices_announce_at_once():
    manager = RacingManager()
    control, hub_end = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    host = DeviceHostProcess(manager, control, cue_quiet_ms=60_000)
    first = threading.Thread(target=host._changed)  # read "handshaking", then stalls
    first.start()
    assert manager.read.wait(2)
    manager.status["ferrovibe"] = "connected"  # meanwhile the FerroVibe connects ...
    second = threading.Thread(target=host._changed)  # ... and its thread announces it
    second.start()
    second.join(0.2)
    manager.hold.set()
    first.join(2)
    second.join(2)
    hub_end.setblocking(False)
    reports = []
    while True:
        try:
            record = msgpack.unpackb(hub_end.recv(65536), raw=False)
        except BlockingIOError:
            break
        if record[0] == "report":
            reports.append(record[1]["status"])
    assert reports[-1] == {"fingertac": "connected", "ferrovibe": "connected"}, reports
