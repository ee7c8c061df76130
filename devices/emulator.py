"""Device emulators: a pseudo-terminal that behaves like the FingerTac, FerroVibe or devkit firmware.

The emulator runs the real firmware core (devices/firmware, through devices.firmware_binding) behind a pty,
so the host's whole byte path (pyserial, framing, handshake, coalescing) is the production one.
It models what the pty cannot:

- the wire: at 115200 8N1 a byte takes 86.8 µs (10 bits). A frame the host writes arrives when
  its last byte would have crossed a real UART, and frames queue behind each other, so an
  over-eager host shows up as latency in the timeline, as it would on hardware;
- the firmware's microsecond timer: pattern edges are stamped at their scheduled time, as a
  hardware-timer alarm fires them (the core is event-driven, see docs/device-protocol.md).

Time is CLOCK_MONOTONIC in µs, the same clock the host uses, so host-side send times and
emulator-side apply times compare directly. Every actuator change goes to the timeline (memory
and, optionally, a CSV file). `unplug()` / `replug()` close the pty and open a new one behind the
same link path, as a USB device that vanishes and comes back.
"""

from __future__ import annotations

import argparse
import csv
import os
import select
import signal
import sys
import threading
import time
import tty
from collections import deque
from pathlib import Path

from devices.firmware_binding import MODELS, Edge, Firmware
from devices.link import BYTE_TIME_S
from devices.messages import PatternMode
from devices.realtime import fifo_this_thread

BYTE_TIME_US = BYTE_TIME_S * 1e6  # 86.8 µs at 115200 8N1
EMULATOR_RT_PRIORITY = 20  # with realtime=True: above the host's device threads (10), below the loop (50)
# temperature_c and friction come last, so readers that index the older columns keep working
TIMELINE_COLUMNS = ("t_us", "channel", "gate", "mode", "intensity_pct", "carrier_hz", "direction_deg",
                    "magnitude_pct", "cause", "temperature_c", "friction")


def edge_row(e: Edge) -> tuple:
    """One timeline row; a temperature or friction layer that is off is an empty cell."""
    return (e.t_us, e.channel, int(e.gate), PatternMode(e.mode).name.lower(), e.intensity, e.carrier_hz,
            e.direction_cdeg / 100, e.magnitude, e.cause, "" if e.temperature_c is None else e.temperature_c,
            "" if e.friction is None else e.friction)


class Emulator:
    def __init__(self, model: str, *, link: str | os.PathLike | None = None, timeline: str | os.PathLike | None = None,
                 wire: bool = True, history: int = 2_000_000, clock_ns=time.monotonic_ns, realtime: bool = False,
                 append_timeline: bool = False):
        self.core = Firmware(model)
        # A device has a CPU of its own: as a measuring instrument (bench latency) the emulator's
        # thread asks for SCHED_FIFO, so its read stamps do not include waiting for a shared core.
        self.realtime = realtime
        self.rt = False
        self.model = model
        self.link = Path(link) if link else None
        self.timeline_path = Path(timeline) if timeline else None
        self.append_timeline = append_timeline  # a restarted emulator goes on in the same file
        self.wire = wire
        self.edges: deque[Edge] = deque(maxlen=history)
        self.received: deque[tuple[int, int]] = deque(maxlen=history)  # (arrival t_us, frame bytes) on the wire
        # (arrival t_us, read t_us, frame bytes) of the same frames: when the frame was read off the
        # pty, i.e. when the host's write reached us, before the modelled wire time (bench latency)
        self.read_at: deque[tuple[int, int, bytes]] = deque(maxlen=history)
        self.bytes_in = 0
        self.bytes_out = 0
        self.dropped_out = 0
        self._clock_ns = clock_ns
        self._master = self._slave = -1
        self.pty_path = ""
        self._pending: deque[tuple[int, bytes, int]] = deque()  # frames in flight: (arrival, bytes, read t_us)
        self._wire_free_us = 0.0
        self._partial = b""
        self._wake_r, self._wake_w = os.pipe()
        os.set_blocking(self._wake_w, False)
        self._requests: deque[tuple[str, bytes, threading.Event]] = deque()
        self._stopping = False
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()  # guards edges/received for readers in other threads
        self._csv = None
        self._csv_file = None

    # ---- control (any thread) -------------------------------------------------------------

    @property
    def path(self) -> str:
        """What a host opens: the link if there is one, else the pty itself."""
        return str(self.link) if self.link else self.pty_path

    def start(self) -> str:
        if self.timeline_path:
            self.timeline_path.parent.mkdir(parents=True, exist_ok=True)
            fresh = not (self.append_timeline and self.timeline_path.exists() and self.timeline_path.stat().st_size)
            self._csv_file = open(self.timeline_path, "w" if fresh else "a", newline="")
            self._csv = csv.writer(self._csv_file)
            if fresh:
                self._csv.writerow(TIMELINE_COLUMNS)
        self._open_pty()
        self._thread = threading.Thread(target=self._run, name=f"emulator-{self.model}", daemon=True)
        self._thread.start()
        return self.path

    def stop(self) -> None:
        self._stopping = True
        self._poke()
        if self._thread:
            self._thread.join(timeout=2)
        self._close_pty()
        os.close(self._wake_r)
        os.close(self._wake_w)
        if self._csv_file:
            self._csv_file.close()

    def unplug(self) -> None:
        """Close the pty as if the USB cable were pulled; the link path disappears."""
        self._request("unplug")

    def replug(self) -> None:
        """A new pty behind the same link path, and a firmware that starts fresh (power cycle)."""
        self._request("replug")

    def inject(self, data: bytes) -> None:
        """Bytes from the "device" that the firmware did not make: noise on the line, for tests."""
        self._request("inject", data)

    def snapshot_edges(self) -> list[Edge]:
        with self._lock:
            return list(self.edges)

    def snapshot_received(self) -> list[tuple[int, int]]:
        with self._lock:
            return list(self.received)

    def snapshot_read_at(self) -> list[tuple[int, int, bytes]]:
        with self._lock:
            return list(self.read_at)

    # ---- internals (emulator thread) ------------------------------------------------------

    def _now_us(self) -> int:
        return self._clock_ns() // 1000

    def _request(self, what: str, data: bytes = b"") -> None:
        done = threading.Event()
        self._requests.append((what, data, done))
        self._poke()
        if not done.wait(2):
            raise TimeoutError(f"emulator did not {what} within 2 s")

    def _poke(self) -> None:
        try:
            os.write(self._wake_w, b"x")
        except BlockingIOError:
            pass

    def _open_pty(self) -> None:
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # no echo, no line discipline: bytes pass unchanged
        os.set_blocking(self._master, False)
        self.pty_path = os.ttyname(self._slave)
        if self.link:
            tmp = self.link.with_name(self.link.name + ".tmp")
            tmp.unlink(missing_ok=True)
            os.symlink(self.pty_path, tmp)
            os.replace(tmp, self.link)  # atomic: a host never sees a half-made link

    def _close_pty(self) -> None:
        if self.link and self.link.is_symlink() and os.readlink(self.link) == self.pty_path:
            self.link.unlink(missing_ok=True)
        for fd in (self._master, self._slave):
            if fd >= 0:
                os.close(fd)
        self._master = self._slave = -1
        self._pending.clear()
        self._partial = b""

    def _handle_requests(self) -> None:
        while self._requests:
            what, data, done = self._requests.popleft()
            if what == "inject" and self._master >= 0:
                os.set_blocking(self._master, True)
                try:
                    os.write(self._master, data)
                finally:
                    os.set_blocking(self._master, False)
            elif what == "unplug":
                self._close_pty()
            elif what == "replug":
                if self._master < 0:
                    self.core = Firmware(self.model)
                    self._open_pty()
            done.set()

    def _read_host(self, now_us: int) -> None:
        try:
            data = os.read(self._master, 4096)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:  # EIO: nobody has the slave open; keep listening
            return
        self.bytes_in += len(data)
        # Split at delimiters so each frame gets its own arrival time on the modelled wire.
        data = self._partial + data
        *frames, self._partial = data.split(b"\x00")
        for body in frames:
            chunk = body + b"\x00"
            if self.wire:
                start = max(float(now_us), self._wire_free_us)
                self._wire_free_us = start + len(chunk) * BYTE_TIME_US
                arrival = int(self._wire_free_us)
            else:
                arrival = now_us
            self._pending.append((arrival, chunk, now_us))

    def _deliver(self, now_us: int) -> None:
        new_edges: list[Edge] = []
        while self._pending and self._pending[0][0] <= now_us:
            t, chunk, read_us = self._pending.popleft()
            new_edges += self.core.advance(t)
            self.core.receive(chunk, t)
            new_edges += self.core.advance(t)
            with self._lock:
                self.received.append((t, len(chunk)))
                self.read_at.append((t, read_us, chunk))
        new_edges += self.core.advance(now_us)
        if new_edges:
            with self._lock:
                self.edges.extend(new_edges)
            if self._csv:
                self._csv.writerows(edge_row(e) for e in new_edges)
        out = self.core.take_output()
        if out and self._master >= 0:
            try:
                self.bytes_out += os.write(self._master, out)
            except OSError:
                self.dropped_out += len(out)

    def _run(self) -> None:
        if self.realtime:
            self.rt = fifo_this_thread(EMULATOR_RT_PRIORITY)
        last_flush = time.monotonic()
        while not self._stopping:
            self._handle_requests()
            now = self._now_us()
            wake = [now + 50_000]
            nxt = self.core.next_edge_us()
            if nxt is not None:
                wake.append(nxt)
            if self._pending:
                wake.append(self._pending[0][0])
            timeout = max(0.0, (min(wake) - now) / 1e6)
            fds = [self._wake_r] + ([self._master] if self._master >= 0 else [])
            readable, _, _ = select.select(fds, [], [], timeout)
            if self._wake_r in readable:
                os.read(self._wake_r, 512)
            now = self._now_us()
            if self._master >= 0 and self._master in readable:
                self._read_host(now)
            self._deliver(now)
            if self._csv_file and time.monotonic() - last_flush > 0.2:
                self._csv_file.flush()
                last_flush = time.monotonic()
        self._handle_requests()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="viestac emulate",
                                     description="Emulate a tactile device on a pseudo-terminal (runs the firmware core).")
    parser.add_argument("model", choices=MODELS)
    parser.add_argument("--link", help="also reachable at this path (a symlink that survives unplug/replug)")
    parser.add_argument("--timeline", help="write the actuator timeline to this CSV file")
    parser.add_argument("--append-timeline", action="store_true",
                        help="append to an existing timeline file (a restarted emulator) instead of starting it afresh")
    parser.add_argument("--no-wire", action="store_true", help="do not model the 115200-baud wire time")
    parser.add_argument("--exit-with-parent", action="store_true", help="stop when the parent process goes away")
    parser.add_argument("--realtime", action="store_true",
                        help=f"run the emulator thread at SCHED_FIFO {EMULATOR_RT_PRIORITY} when allowed (a device has "
                             "a CPU of its own; starved by a loaded machine, it would stamp frames late and trip its watchdog)")
    args = parser.parse_args(argv)
    # Handlers before the path is printed: whoever reads it may stop us at once, and must get the
    # orderly stop (timeline flushed, pty closed), not the default SIGTERM death.
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    # Nothing reads the in-memory history of a separate emulator process (its timeline is the CSV
    # file): keep only a little, or a long session (the simulated rig) grows by ~400 B per frame.
    emulator = Emulator(args.model, link=args.link, timeline=args.timeline, wire=not args.no_wire, history=1000,
                        append_timeline=args.append_timeline, realtime=args.realtime)
    path = emulator.start()
    print(f"{args.model} emulator on {emulator.pty_path}" + (f" (link {path})" if args.link else ""), flush=True)
    print(path, flush=True)
    parent = os.getppid()
    while not stop.wait(0.5):
        if args.exit_with_parent and os.getppid() != parent:
            break  # the server died without stopping us (e.g. SIGKILL)
    emulator.stop()
    c = emulator.core.counters()
    print(f"{args.model} emulator stopped: {emulator.bytes_in} bytes in, {c.get('frames_ok', 0)} frames, "
          f"{sum(v for k, v in c.items() if k != 'frames_ok')} rejected/errors", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
