"""DeviceFeed: the loop's cue records → the DeviceManager, on a thread of its own.

The loop sends a `["cues", tick, sent_ns, [cue, ...]]` record on the cue channel (server/ipc.py)
in every tick whose cues differ from what the devices were last given, before that tick's state
record. The feed runs in the device host process (devices/host_process.py), never on the hub's
event loop: with 64 viewers that loop is busy sending the same tick's frame to every viewer right
when a cue changes (docs/performance.md "Tracker → device latency"). The thread sleeps in `recv`,
runs at SCHED_FIFO below the loop when allowed (devices/realtime.py), and hands each cue set to
the DeviceManager with `write_now`: it writes a device's first frame itself only when the link
budget allows and the port's output queue is empty, so the write cannot block, and leaves the
rest to the device's writer thread; a dead or slow device cannot hold the feed up.
"""

from __future__ import annotations

import logging
import socket
import threading
import time
from collections import deque

import msgpack

from server.core.cues import cue_from_wire
from devices.realtime import fifo_this_thread
from server import ipc

log = logging.getLogger("viestac.devices")


class DeviceFeed:
    def __init__(self, manager):
        self.manager = manager
        self.records = 0
        self.bad_records = 0
        self.last_tick: int | None = None
        self.rt = False
        self.stopped = False  # set when the host stops: later records are dropped (everything stays off)
        self.delays_ns: deque[tuple[int, int]] = deque(maxlen=1000)  # loop send → (received, handed over)
        self.thread: threading.Thread | None = None

    def handle(self, record: list, received_ns: int | None = None) -> None:
        """One cue record: decode and hand it to the devices; ValueError names what is wrong.
        With `received_ns`, the hop from the loop's send to the hand-over is kept (info())."""
        if not (isinstance(record, list) and len(record) == 4 and record[0] == "cues" and isinstance(record[3], list)
                and isinstance(record[2], int)):
            raise ValueError(f"not a cue record: {record!r:.120}")
        cues = tuple(cue_from_wire(c) for c in record[3])
        if self.stopped:
            return
        self.manager.submit(cues, write_now=True)
        self.records += 1
        self.last_tick = record[1]
        if received_ns is not None:
            self.delays_ns.append((received_ns - record[2], time.monotonic_ns() - record[2]))

    def attach(self, sock: socket.socket) -> None:
        """Serve the cue channel on a thread of its own until every holder of its other end closed it."""
        self.thread = threading.Thread(target=self._run, args=(sock,), name="device-feed", daemon=True)
        self.thread.start()

    def info(self) -> dict:
        """Counts, and the hop from the loop's send to the feed (received, handed to the devices)
        over the last 1000 cue changes, in µs."""
        delays = list(self.delays_ns)
        hop = {}
        for i, name in enumerate(("received", "handed_over")):
            values = sorted(d[i] for d in delays)
            hop[name] = ({"p50_us": round(values[len(values) // 2] / 1000, 1),
                          "p99_us": round(values[min(len(values) - 1, int(len(values) * 0.99))] / 1000, 1),
                          "max_us": round(values[-1] / 1000, 1)} if values else None)
        return {"records": self.records, "bad_records": self.bad_records, "last_tick": self.last_tick, "rt": self.rt,
                "delay": hop}

    def _run(self, sock: socket.socket) -> None:
        self.rt = fifo_this_thread()
        sock.setblocking(True)
        with sock:
            while True:
                try:
                    data = sock.recv(ipc.MAX_RECORD_BYTES)
                except OSError:
                    return
                if not data:
                    return  # nobody can send any more
                received_ns = time.monotonic_ns()
                try:
                    self.handle(msgpack.unpackb(data, raw=False), received_ns)
                except Exception:  # noqa: BLE001 - one bad record must not stop the devices' feed
                    self.bad_records += 1
                    if self.bad_records <= 10 or self.bad_records % 1000 == 0:
                        log.exception("device feed: bad cue record (%d so far)", self.bad_records)
