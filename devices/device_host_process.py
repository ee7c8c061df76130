"""The device host process: the rig's serial devices, in a process of their own.

Why not in the hub process: its event loop sends every tick's frame to every viewer, and on a
2-core machine with 64 viewers any other thread there waits for the GIL (and for the CPU the GIL
holder needs) every time it wakes: the device feed and writer threads lost 0.2-0.6 ms at each of
their two wake-ups per cue change (docs/performance.md "Tracker → device latency"). Here the
only Python threads are the devices' own (reader, writer; SCHED_FIFO for the writers) and the
feed, which blocks in `recv` on the cue channel the loop process writes to directly.

Started by the hub (server/hub/device_host.py) as
`python -m devices.device_host_process --control-fd C --cues-fd Q`, with the pickled device configs on
stdin. Control records on a SEQPACKET socket: server/ipc/records.py TO_DEVICE_HOST (snapshot,
stop) and FROM_DEVICE_HOST (hello, report, profiles, snapshot); docs/architecture.md "The mailbox"
has their tables. A closed control socket (the hub died) is a stop. Stopping turns every actuator off first; so does
a cue channel that breaks (nobody can drive the devices any more) or goes quiet (devices/feed.py).
`--cue-quiet-ms` sets the feed's quiet time (default devices.feed.CUE_QUIET_MS).
"""

from __future__ import annotations

import argparse
import logging
import os
import pickle
import socket
import sys
import threading

from devices.feed import CUE_QUIET_MS, DeviceFeed
from devices.manager import DeviceManager
from server import ipc
from server.log_repeats import limit_repeats
from server.ipc.records import (TO_DEVICE_HOST, DeviceProfiles, DeviceStatus, Hello, Record, Snapshot,
                                SnapshotRequest, Stop)

log = logging.getLogger("viestac.devices")


class DeviceHostProcess:
    """The child's side: a DeviceManager, the cue feed, and the hub's control channel."""

    def __init__(self, manager: DeviceManager, control: socket.socket, *, cue_quiet_ms: float = CUE_QUIET_MS):
        self.manager = manager
        self.control = control
        self.feed = DeviceFeed(manager, quiet_ms=cue_quiet_ms)
        self.feed.on_closed = self.all_off
        self._send_lock = threading.Lock()  # reports come from device threads, replies from the control thread
        # Each device's threads announce its changes: reading the manager and sending what changed
        # is one step, or a thread that read before another's change could send its older report
        # last, and the hub would keep it (a device shown handshaking that had connected long ago).
        self._report_lock = threading.Lock()
        self._report: dict | None = None
        self._profiles: dict | None = None
        manager.listeners.append(self._changed)

    def send(self, record: Record) -> None:
        with self._send_lock:
            try:
                self.control.sendall(ipc.pack(record))
            except OSError:
                pass  # the hub is gone; the control thread sees it and stops

    def _changed(self) -> None:
        """A device's status, identity or refusals changed: tell the hub what it needs."""
        with self._report_lock:
            report = self.manager.report()
            if report != self._report:
                self._report = report
                self.send(DeviceStatus(report))
            profiles = {name: d.profile.to_table() for name, d in self.manager.devices.items()}
            if profiles != self._profiles:
                self._profiles = profiles
                self.send(DeviceProfiles(profiles))

    def all_off(self) -> None:
        """Every actuator off for good: later cue records are dropped."""
        self.feed.stopped = True  # a cue still in the channel must not turn anything back on
        self.manager.submit((), write_now=True)

    def run(self, cues: socket.socket) -> None:
        self.manager.start()
        self.feed.attach(cues)
        self.send(Hello({"pid": os.getpid()}))
        self._changed()
        try:
            self._serve_control()
        finally:
            self.all_off()  # first: the drain in stop() sends these before the ports close
            self.manager.stop()

    def _serve_control(self) -> None:
        self.control.setblocking(True)
        while True:
            try:
                data = self.control.recv(ipc.MAX_RECORD_BYTES)
            except OSError:
                return
            if not data:
                return
            try:
                match ipc.unpack(data, TO_DEVICE_HOST):
                    case Stop():
                        return
                    case SnapshotRequest(request, writes):
                        self.send(Snapshot(request, {**self.manager.snapshot(int(writes)), "feed": self.feed.info()}))
            except Exception:  # noqa: BLE001 - one bad request must not take the devices down
                log.exception("device host: bad control record %r", data[:80])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="viestac-devices")
    parser.add_argument("--control-fd", type=int, required=True)
    parser.add_argument("--cues-fd", type=int, required=True)
    parser.add_argument("--cue-quiet-ms", type=float, default=CUE_QUIET_MS,
                        help="every actuator off when the cue channel is quiet this long (the loop died or stalls)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(levelname)s %(message)s")
    limit_repeats()  # e.g. a watchdog trip every half second: the first at once, then a count
    configs = pickle.loads(sys.stdin.buffer.read())  # from the hub, our parent: trusted
    control = socket.socket(fileno=args.control_fd)
    cues = socket.socket(fileno=args.cues_fd)
    DeviceHostProcess(DeviceManager(configs), control, cue_quiet_ms=args.cue_quiet_ms).run(cues)
    return 0


if __name__ == "__main__":
    sys.exit(main())
