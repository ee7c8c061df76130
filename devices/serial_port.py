"""SerialDevice: one configured device on a serial port — pyserial and two threads around a
sans-I/O protocol (devices.protocol.DeviceSession or devices.line_protocol.LineProtocol).

No domain logic lives here. The reader thread owns the connection: it resolves the port (a
path or USB VID/PID/serial number), opens it, feeds every byte it reads to the protocol, and on
any read error (unplug, Bluetooth link lost) closes the port, reports "disconnected" and tries
again every `reopen_interval_s`. The writer thread asks the protocol what to write and when to
ask again (the link budget, heartbeats), and sleeps in between. `set_commands` takes a lock only
for the time of a dict update, so its caller (the device feed in the device host process) never
waits on a serial port: with `write_now` it writes one frame itself, and only when the port's
output queue is empty (docs/device-protocol.md §4–5). The 1 kHz loop, in a process of its own,
never reaches this code.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable

import serial

from devices.ports import PortSpec, latency_warning, resolve
from devices.realtime import fifo_this_thread

log = logging.getLogger("viestac.devices")
# A write blocks only when the port's output buffer is full: the device (an emulator starved on a
# loaded machine) has not read for a while. 0.5 s dropped the link 9 times in a 33-minute run beside
# a CPU hog ("write failed: Write timeout"), each a reconnect and a resend of every layer. Only the
# writer thread waits this long (the feed never writes to a busy port), and a dead device is found
# by the reader anyway (a read error, or silence: unresponsive after 1.5 s).
WRITE_TIMEOUT_S = 2.0
_ROUTINE = {"Acked", "Pong"}  # counted by the protocol, not kept in the event list


class SerialDevice:
    def __init__(self, name: str, spec: PortSpec, protocol, *, baud: int = 115200, reopen_interval_s: float = 0.5,
                 on_event: Callable[[str, object], None] | None = None, clock: Callable[[], float] = time.monotonic,
                 serial_factory=serial.Serial):
        self.name = name
        self.spec = spec
        self.protocol = protocol
        self.baud = baud
        self.reopen_interval_s = reopen_interval_s
        self.on_event = on_event
        self.clock = clock
        self.serial_factory = serial_factory
        self.path: str | None = None
        self._target: str | None = None  # what self.path led to when it was opened (a link's target)
        self._target_checked = 0.0
        self.warning: str | None = None
        self.last_error = ""  # with its time, last_error_at (a property below)
        self.connects = 0
        self.disconnects = 0
        self.events: deque[dict] = deque(maxlen=200)  # recent facts, for the console
        self._port: serial.Serial | None = None
        self._cond = threading.Condition()
        self._kick = False  # set with every wake-up of the writer, cleared when it polls
        self._write_lock = threading.Lock()  # one writer of frames at a time: the writer thread or the feed
        self._running = False
        self._threads: list[threading.Thread] = []
        self.writer_rt = False  # the writer thread got SCHED_FIFO
        # (CLOCK_MONOTONIC ns when write() returned, bytes) of the latest writes: when a command was
        # handed to the port, for the tracker -> device latency (viestac bench latency)
        self.writes: deque[tuple[int, bytes]] = deque(maxlen=1024)

    # ---- public, any thread --------------------------------------------------------------

    def start(self) -> None:
        self._running = True
        self._threads = [threading.Thread(target=self._run_reader, name=f"{self.name}-reader", daemon=True),
                         threading.Thread(target=self._run_writer, name=f"{self.name}-writer", daemon=True)]
        for thread in self._threads:
            thread.start()

    def stop(self, drain_s: float = 0.3) -> None:
        """Stop the threads, after at most `drain_s` for the commands still waiting (the last
        ones are usually "everything off": a device must not buzz on after the server quits)."""
        deadline = time.monotonic() + drain_s
        with self._cond:
            while self._port is not None and self.protocol.book.pending and time.monotonic() < deadline:
                self._cond.wait(0.01)
            self._running = False
            self._wake()
        self._drop("stopped", report=False)
        for thread in self._threads:
            thread.join(timeout=2)

    def set_commands(self, commands: Iterable[object], *, write_now: bool = False) -> None:
        """The newest value of each layer; never blocks on the port.

        With `write_now` (the device feed, devices/feed.py) the caller also writes the first frame
        itself when the link budget allows it and the port's output queue is empty, so the write
        cannot block; that saves the writer thread's wake-up (~0.1-0.3 ms on this VM). The rest
        (a busy budget, more frames, heartbeats) stays with the writer thread."""
        now = self.clock()
        with self._cond:
            for command in commands:
                self.protocol.set(command, now)
            if not write_now:
                self._wake()
        if not write_now:
            return
        if self._write_lock.acquire(blocking=False):  # else the writer thread is at it already
            try:
                self._write_inline()
            finally:
                self._write_lock.release()
        with self._cond:
            self._wake()  # after the write: the rest (and the events) are the writer thread's

    def _write_inline(self) -> None:
        port = self._port
        try:
            if port is None or port.out_waiting:
                return
        except (serial.SerialException, OSError, TypeError, AttributeError, ValueError):
            return  # the threads find out what is wrong with the port
        with self._cond:
            if port is not self._port:
                return
            data, _ = self.protocol.poll(self.clock())  # its events stay queued for the threads
        if data:
            self._write(port, data, drop_on_error=False)  # the caller may hold the manager's lock: no events here

    def _write(self, port, data: bytes, *, drop_on_error: bool = True) -> None:
        """One frame to the port, with the write lock held. A failed inline write is left to the
        threads: the reader's next read fails the same way and reports it, and the frame is
        resent when its ACK does not come."""
        try:
            port.write(data)
            self.writes.append((time.monotonic_ns(), data))
        except (serial.SerialException, OSError, TypeError, AttributeError) as exc:
            self.last_error = f"write failed: {exc}"
            if drop_on_error:
                self._drop(self.last_error)

    def _wake(self) -> None:
        """With the condition held: something for the writer to look at (no wake-up is lost)."""
        self._kick = True
        self._cond.notify_all()

    @property
    def last_error(self) -> str:
        return self._last_error

    @last_error.setter
    def last_error(self, text: str) -> None:
        self._last_error = text
        self.last_error_at = time.time() if text else None  # wall clock: the console shows its age

    @property
    def status(self) -> str:
        return self.protocol.status

    def snapshot(self, writes: int = 0) -> dict:
        """The console's view; `writes` > 0 adds the latest writes as [t_ns, hex]."""
        recent = [[t, data.hex()] for t, data in list(self.writes)[-writes:]] if writes > 0 else None
        with self._cond:
            identity = self.protocol.identity
            return {"name": self.name, "port": str(self.spec), "path": self.path, "status": self.protocol.status,
                    "identity": _identity_dict(identity), "rtt_ms": None if self.protocol.rtt_s is None
                    else round(self.protocol.rtt_s * 1000, 3), "counters": dict(self.protocol.counters),
                    "connects": self.connects, "disconnects": self.disconnects, "last_error": self.last_error,
                    "last_error_at": self.last_error_at, "warning": self.warning, "writer_rt": self.writer_rt, "events": list(self.events)[-20:],
                    **({"writes": recent} if recent is not None else {})}

    # ---- threads -------------------------------------------------------------------------

    def _run_reader(self) -> None:
        while self._running:
            port = self._port
            if port is None:
                if not self._open():
                    with self._cond:
                        self._cond.wait(self.reopen_interval_s)
                continue
            if self._moved():
                continue
            try:
                data = port.read(max(1, port.in_waiting))
            except (serial.SerialException, OSError, TypeError, AttributeError) as exc:
                # TypeError/AttributeError: pyserial's read on a port another thread just closed
                self._drop(f"read failed: {exc}")
                continue
            if data:
                with self._cond:
                    self.protocol.receive_data(data, self.clock())
                    events = self.protocol.events_received()
                    self._wake()
                self._publish(events)

    def _run_writer(self) -> None:
        self.writer_rt = fifo_this_thread()  # woken by a new cue while other work keeps both CPUs busy
        while True:
            with self._write_lock:  # polled and written in one go, so frames leave in sequence order
                with self._cond:
                    if not self._running:
                        return
                    self._kick = False
                    port = self._port
                    data, wake_at = (self.protocol.poll(self.clock()) if port is not None else (b"", None))
                    events = self.protocol.events_received()
                if data:
                    self._write(port, data)
            self._publish(events)
            if not data:
                with self._cond:
                    if self._running and not self._kick:  # nothing new since the poll
                        timeout = 0.25 if wake_at is None else min(0.25, max(0.0, wake_at - self.clock()))
                        self._cond.wait(timeout)

    def _moved(self) -> bool:
        """A configured link (a by-id path, an emulator's link) that now leads somewhere else: the
        device came back on another node while we hold the old one, which may even be somebody
        else's port by now (a dead emulator's pty number is reused). Drop it and reopen the link.
        Checked once per reopen interval, from the reader thread."""
        now = self.clock()
        if self.spec.path is None or self._target is None or now - self._target_checked < self.reopen_interval_s:
            return False
        self._target_checked = now
        target = os.path.realpath(self.spec.path)
        if target == self._target:
            return False
        self._drop(f"{self.spec.path} now leads to {target}, not {self._target}")
        return True

    def _open(self) -> bool:
        path = resolve(self.spec, on_warning=self._warn)
        if path is None:
            self.last_error = f"port {self.spec} not present"
            return False
        try:
            port = self.serial_factory(path, self.baud, timeout=0.1, write_timeout=WRITE_TIMEOUT_S)
        except (serial.SerialException, OSError, ValueError) as exc:
            self.last_error = f"cannot open {path}: {exc}"
            return False
        self.path = path
        self._target, self._target_checked = os.path.realpath(path), self.clock()
        self.warning = latency_warning(path)
        if self.warning:
            log.warning("%s: %s", self.name, self.warning)
        with self._cond:
            self._port = port
            self.connects += 1
            self.protocol.connection_made(self.clock())
            events = self.protocol.events_received()
            self._wake()
        log.debug("%s: opened %s", self.name, path)
        self._publish(events)
        return True

    def _drop(self, reason: str, *, report: bool = True) -> None:
        with self._cond:
            port, self._port = self._port, None
            if port is None:
                return
            self.disconnects += report
            self.last_error = reason
            self.protocol.connection_lost(self.clock(), reason)
            events = self.protocol.events_received()
            self._wake()
        try:
            port.close()
        except Exception:  # the port is gone already; closing is best effort
            pass
        self._publish(events)  # the StatusChanged event carries the reason to the log

    def _warn(self, text: str) -> None:
        self.warning = text
        log.warning("%s: %s", self.name, text)

    def _publish(self, events: list) -> None:
        for event in events:
            if type(event).__name__ not in _ROUTINE:  # hundreds per second would push out what matters
                self.events.append({"t": time.time(), "event": type(event).__name__, **_event_fields(event)})
            if self.on_event:
                self.on_event(self.name, event)


def _identity_dict(identity) -> dict | None:
    if identity is None:
        return None
    return {f.name: getattr(identity, f.name) for f in dataclasses.fields(identity)}


def _event_fields(event) -> dict:
    out = {}
    for f in dataclasses.fields(event) if dataclasses.is_dataclass(event) else ():
        key, value = f.name, getattr(event, f.name)
        out[key] = value if isinstance(value, (int, float, str, bool, type(None))) else repr(value)
    return out
