"""DeviceFeed: the loop's cue records → the DeviceManager, on a thread of its own.

The loop sends a `Cues` record (server/ipc/records.py) on the cue channel in every tick whose
cues differ from what the devices were last given, before that tick's state record; with several
tools (fingers) its `fingers` carry every other tool's cues, and each device gets its own finger's (devices/manager.py). Without it, a device on
another finger gets nothing: a fail-safe `[]` turns every device off. The feed runs in the device host process (devices/device_host_process.py), never on the hub's
event loop: with 64 viewers that loop is busy sending the same tick's frame to every viewer right
when a cue changes (docs/performance.md "Tracker → device latency"). The thread sleeps in `recv`,
runs at SCHED_FIFO below the loop when allowed (devices/realtime.py), and hands each cue set to
the DeviceManager with `write_now`: it writes a device's first frame itself only when the link
budget allows and the port's output queue is empty, so the write cannot block, and leaves the
rest to the device's writer thread; a dead or slow device cannot hold the feed up.

Fail safe (docs/devices.md "Faults"): the loop also sends an `Alive` record whenever it
sent nothing on the channel for CUE_HEARTBEAT_MS, so a channel that stays quiet for
`quiet_ms` (CUE_QUIET_MS) means the loop died or stalls: the feed turns every actuator off
itself, without waiting for anyone to notice the dead process, and re-applies the last cue set
when records resume (a restarted loop sends its own cues at its first tick). The decisions are
sans-I/O (`handle`, `check` with the time as an argument); the thread only waits in `recv` with a
timeout up to the next deadline.
"""

from __future__ import annotations

import logging
import socket
import threading
import time
from collections import deque

from server.core.cues import cue_from_wire
from devices.realtime import fifo_this_thread
from server import ipc
from server.ipc.records import CUES, Alive, Cues, Record

log = logging.getLogger("viestac.devices")

CUE_HEARTBEAT_MS = 10  # the loop sends "alive" when it sent nothing on the cue channel for this long
CUE_QUIET_MS = 30      # nothing at all for this long: every actuator off (3 heartbeats missed)


class DeviceFeed:
    def __init__(self, manager, *, quiet_ms: float = CUE_QUIET_MS):
        if not quiet_ms > CUE_HEARTBEAT_MS:
            raise ValueError(f"quiet_ms must exceed the loop's heartbeat ({CUE_HEARTBEAT_MS} ms), got {quiet_ms!r}")
        self.manager = manager
        self.quiet_ns = int(quiet_ms * 1_000_000)
        self.records = 0
        self.alive = 0
        self.bad_records = 0
        self.quiet_offs = 0  # times the channel went quiet and the feed turned everything off
        self.quiet = False   # off because the channel is quiet; the next record re-applies `cues`
        self.cues: tuple = ()  # the last cue set the loop sent (the primary tool's)
        self.finger_cues: dict[str, tuple] = {}  # and the other tools', by point name
        self._last_rx_ns: int | None = None  # None until the first record: the devices start off
        self.last_tick: int | None = None
        self.rt = False
        self.stopped = False  # set when the host stops: later records are dropped (everything stays off)
        self.delays_ns: deque[tuple[int, int]] = deque(maxlen=1000)  # loop send → (received, handed over)
        self.thread: threading.Thread | None = None
        self.on_closed = None  # called on the feed thread when the cue channel breaks for good

    def handle(self, record: Record, received_ns: int | None = None) -> None:
        """One record (Cues or Alive): hand the cues to the devices; ValueError names what is
        wrong. `received_ns` (time.monotonic_ns) restarts the quiet timer and keeps the hop
        from the loop's send to the hand-over (info()); without it the record still counts as a
        sign of life at the current time."""
        now_ns = time.monotonic_ns() if received_ns is None else received_ns
        if type(record) is Alive:
            self.alive += 1
            self.last_tick = record.tick
            self._last_rx_ns = now_ns
            if self.quiet and not self.stopped:  # the loop is back (or never died, only stalled)
                self.quiet = False
                self._submit()
            return
        if type(record) is not Cues:
            raise ValueError(f"not a cue record: {record!r:.120}")
        cues = tuple(cue_from_wire(c) for c in record.cues)
        fingers = {name: tuple(cue_from_wire(c) for c in given) for name, given in record.fingers.items()} \
            if record.fingers is not None else {}
        self._last_rx_ns = now_ns
        if self.stopped:
            return
        self.cues, self.finger_cues, self.quiet = cues, fingers, False
        self._submit()
        self.records += 1
        self.last_tick = record.tick
        if received_ns is not None:
            self.delays_ns.append((received_ns - record.sent_ns, time.monotonic_ns() - record.sent_ns))

    def _submit(self) -> None:
        if self.finger_cues:  # several fingers: each device gets its own (devices/manager.py)
            self.manager.submit(self.cues, write_now=True, finger_cues=self.finger_cues)
        else:
            self.manager.submit(self.cues, write_now=True)

    def check(self, now_ns: int) -> int | None:
        """The quiet rule at `now_ns`: every actuator off once nothing arrived for quiet_ms.
        Returns when to check again (ns), None while there is nothing to wait for (no record yet,
        already off, or stopped)."""
        if self._last_rx_ns is None or self.quiet or self.stopped:
            return None
        deadline = self._last_rx_ns + self.quiet_ns
        if now_ns < deadline:
            return deadline
        self.quiet = True
        self.quiet_offs += 1
        self.manager.submit((), write_now=True)
        if self.quiet_offs <= 10 or self.quiet_offs % 100 == 0:
            log.warning("device feed: no record from the loop for %.0f ms: every actuator off (%d so far)",
                        (now_ns - self._last_rx_ns) / 1e6, self.quiet_offs)
        return None

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
        return {"records": self.records, "alive": self.alive, "bad_records": self.bad_records,
                "last_tick": self.last_tick, "rt": self.rt, "quiet": self.quiet, "quiet_offs": self.quiet_offs,
                "quiet_ms": self.quiet_ns / 1e6, "delay": hop}

    def _run(self, sock: socket.socket) -> None:
        self.rt = fifo_this_thread()
        with sock:
            while True:
                deadline = self.check(time.monotonic_ns())
                # a timeout makes the socket non-blocking underneath and waits in poll(): recv
                # returns at the quiet deadline even when the loop is gone for good
                sock.settimeout(None if deadline is None else max(0.0, (deadline - time.monotonic_ns()) / 1e9))
                try:
                    data = sock.recv(ipc.MAX_RECORD_BYTES)
                except TimeoutError:
                    continue
                except OSError:
                    break
                if not data:
                    break  # nobody can send any more
                received_ns = time.monotonic_ns()
                try:
                    self.handle(ipc.unpack(data, CUES), received_ns)
                except Exception:  # noqa: BLE001 - one bad record must not stop the devices' feed
                    self.bad_records += 1
                    if self.bad_records <= 10 or self.bad_records % 1000 == 0:
                        log.exception("device feed: bad cue record (%d so far)", self.bad_records)
        if self.on_closed is not None:  # the channel is gone: nobody will drive the devices again
            self.on_closed()
