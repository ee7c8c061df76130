"""The tracker host process: runs the configured tracker sources outside the loop and the hub.

Started by the hub (server/hub/tracker_host.py) as
`python -m server.tracking.tracker_host_process --control-fd C --udp HOST:PORT --data-dir DIR`, with the
source specs as JSON on stdin. For every sample of every source: calibrate, 1€-filter each point
(server/tracking/pipeline.py) and send one `tracker` datagram (msgpack) to the loop's tracker UDP
port, from one UDP socket per source (so the loop tells the sources apart, and a source that
stops is released by its `ttl` in the loop itself, whatever this process does). The hub's event
loop is never on this path.

Control records on a SEQPACKET socket: server/ipc/records.py TO_TRACKER_HOST (calibrate, capture,
stop) and FROM_TRACKER_HOST (hello, health every HEALTH_EVERY_S, answer); docs/architecture.md
"The mailbox" has their tables.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import os
import socket
import sys
import time
from collections import deque
from pathlib import Path

import msgpack

from devices.realtime import fifo_this_thread
from server import ipc
from server.log_repeats import limit_repeats
from server.ipc.records import (TO_TRACKER_HOST, Answer, Calibrate, Capture, Hello, Malformed, Record, SourcesHealth,
                                Stop)
from server.tracking import sources, store
from server.tracking.calibration import Calibration
from server.tracking.health import SourceHealth
from server.tracking.one_euro import DEFAULT_PARAMS
from server.tracking.pipeline import SourcePipeline
from server.tracking.sources import SourceSpec

log = logging.getLogger("viestac.tracking")

HEALTH_EVERY_S = 0.1
RAW_KEEP_S = 3.0           # raw samples kept for a calibration capture
MAX_DATAGRAM = 8192        # well below the tracker port's datagram limit (server/loop/tracker_udp.py)


def _encode(message: dict, keep_side: str) -> bytes:
    data = msgpack.packb(message, use_bin_type=True)
    if len(data) > MAX_DATAGRAM and "points" in message:  # two whole hands: keep the driving hand's joints
        message = dict(message)
        message["points"] = {n: p for n, p in message["points"].items() if n.startswith(keep_side)}
        data = msgpack.packb(message, use_bin_type=True)
    return data


class Source:
    def __init__(self, spec: SourceSpec, calibration: Calibration, target: tuple[str, int]):
        self.spec = spec
        self.pipeline = SourcePipeline(spec.name, calibration, nominal_hz=spec.nominal_hz,
                                       filter_params=DEFAULT_PARAMS if sources.KINDS[spec.kind].filtered else None)
        self.health = SourceHealth(spec.name, spec.kind, spec.nominal_hz, self.pipeline.ttl / 1000.0)
        self.target = target
        family = socket.AF_INET6 if ":" in target[0] else socket.AF_INET
        self.sock = socket.socket(family, socket.SOCK_DGRAM)
        self.sock.setblocking(False)
        # Bound now, so its health names the source as the loop does (`tracking.lost`, the applied
        # rows): "udp:HOST:PORT" of this socket (the tracker port is on loopback, as is this end).
        self.sock.bind((target[0], 0))
        local = self.sock.getsockname()
        self.client_id = f"udp:{local[0]}:{local[1]}"
        self.raw: deque = deque()  # (monotonic s, raw points)
        self.sent = 0
        self.send_errors = 0

    def sample(self, raw_points: dict, t_s: float, confidence: float) -> None:
        now = time.monotonic()
        message = self.pipeline.process(raw_points, t_s, stamp_ms=time.monotonic_ns() / 1e6)
        if message is None:
            return
        self.raw.append((now, raw_points))
        while self.raw and self.raw[0][0] < now - RAW_KEEP_S:
            self.raw.popleft()
        try:
            self.sock.sendto(_encode(message, message["point"].split(".", 1)[0]), self.target)
            self.sent += 1
        except OSError:  # a full buffer: the next sample replaces this one anyway
            self.send_errors += 1
        self.health.sample(now, confidence)

    def capture(self, seconds: float) -> dict:
        """The mean raw position of each point over the last `seconds`, and its spread."""
        now = time.monotonic()
        rows = [pts for t, pts in self.raw if t >= now - seconds]
        if not rows:
            return {"ok": False, "error": f"no samples from {self.spec.name} in the last {seconds:g} s"}
        out = {}
        for name in rows[-1]:
            ps = [r[name] for r in rows if name in r]
            mean = [sum(p[i] for p in ps) / len(ps) for i in range(3)]
            spread = max(sum((p[i] - mean[i]) ** 2 for i in range(3)) ** 0.5 for p in ps)
            out[name] = {"mean": mean, "spread": spread, "samples": len(ps)}
        return {"ok": True, "points": out, "units": self.pipeline.calibration.units}

    async def run(self) -> None:
        await sources.KINDS[self.spec.kind].run(self)  # its kind's module (server/tracking/sources.py)


class TrackerHostProcess:
    def __init__(self, control: socket.socket, specs: list[SourceSpec], target: tuple[str, int], data_dir: Path,
                 rt: bool = False):
        self.control = control
        self.rt = rt
        self.data_dir = data_dir
        self.sources = {s.name: Source(s, store.load(data_dir, s.name, s.kind), target) for s in specs}
        self.stopped = asyncio.Event()

    def _send(self, record: Record) -> None:
        try:
            ipc.send_record(self.control, record)
        except OSError:
            self.stopped.set()

    def health(self) -> list[dict]:
        now = time.monotonic()
        out = []
        for src in self.sources.values():
            snap = src.health.snapshot(now)
            snap.update(sent=src.sent, send_errors=src.send_errors, outside=src.pipeline.outside, client_id=src.client_id,
                        target=src.spec.target, calibration=src.pipeline.calibration.to_dict(),
                        ttl_ms=src.pipeline.ttl)
            out.append(snap)
        return out

    def _on_control(self) -> None:
        try:
            records = ipc.drain(self.control, TO_TRACKER_HOST)
        except ipc.PeerClosed:
            self.stopped.set()
            return
        for record in records:
            self._handle(record)

    def _handle(self, record: Record | Malformed) -> None:
        match record:
            case Stop():
                self.stopped.set()
            case Malformed(error):
                log.error("tracker host: bad control record: %s", error)
            case Capture(request, name, seconds) if name not in self.sources:
                self._send(Answer(request, {"ok": False, "error": f"no tracker source {name!r}"}))
            case Calibrate(request, name, _) if name not in self.sources:
                self._send(Answer(request, {"ok": False, "error": f"no tracker source {name!r}"}))
            case Capture(request, name, seconds):
                self._send(Answer(request, self.sources[name].capture(float(seconds))))
            case Calibrate(request, name, table):
                self._calibrate(request, self.sources[name], table)

    def _calibrate(self, request: int, src: Source, table: dict | None) -> None:
        name = src.spec.name
        try:
            if table is None:
                store.remove(self.data_dir, name)
                calibration = store.default_for(src.spec.kind)
            else:
                calibration = Calibration.from_dict(table)
                store.save(self.data_dir, name, calibration)
        except (ValueError, KeyError, TypeError, OSError) as exc:
            self._send(Answer(request, {"ok": False, "error": str(exc)}))
            return
        src.pipeline.set_calibration(calibration)
        self._send(Answer(request, {"ok": True, "calibration": calibration.to_dict()}))

    async def run(self) -> None:
        loop = asyncio.get_running_loop()
        loop.add_reader(self.control.fileno(), self._on_control)
        self._send(Hello({"pid": os.getpid(), "rt": self.rt}))
        tasks = [asyncio.create_task(self._guard(src)) for src in self.sources.values()]
        while not self.stopped.is_set():
            self._send(SourcesHealth(self.health()))
            try:
                await asyncio.wait_for(self.stopped.wait(), HEALTH_EVERY_S)
            except asyncio.TimeoutError:
                pass
        for task in tasks:
            task.cancel()

    async def _guard(self, src: Source) -> None:
        """A source whose task fails (a bad file, a bug) is reported and tried again, never
        taking the other sources down."""
        while True:
            try:
                await src.run()
                return
            except asyncio.CancelledError:
                raise
            except Exception as exc:  # noqa: BLE001
                log.exception("tracker source %s failed", src.spec.name)
                src.health.note, src.health.connected = f"failed: {exc}", False
                await asyncio.sleep(1.0)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m server.tracking.tracker_host_process")
    parser.add_argument("--control-fd", type=int, required=True)
    parser.add_argument("--udp", required=True, help="the loop's tracker UDP port, HOST:PORT")
    parser.add_argument("--data-dir", required=True)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    limit_repeats()  # a lost source's retries: the first at once, then a count (server/log_repeats.py)
    specs = [SourceSpec.from_dict(t) for t in json.loads(sys.stdin.read() or "[]")]
    host, _, port = args.udp.rpartition(":")
    control = socket.socket(fileno=args.control_fd)
    control.setblocking(False)
    # On the tracker → device path, like the device host's threads: SCHED_FIFO below the loop when
    # allowed, so a sample is not left waiting for a CPU while the hub broadcasts (devices/realtime.py).
    rt = fifo_this_thread()
    tracker = TrackerHostProcess(control, specs, (host.strip("[]"), int(port)), Path(args.data_dir), rt=rt)
    asyncio.run(tracker.run())
    return 0


if __name__ == "__main__":
    sys.exit(main())
