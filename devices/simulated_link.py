"""A simulated serial line between a host protocol and a device, on simulated time. No ports, no
sleeps (like h11's ConnectionPair).

SimulatedLink moves whole writes across a line of `byte_time_s` per byte (both directions
serialised, plus a fixed latency) and polls the host exactly when its poll() asked to be
called again, after something was received, or after a set() that answers that a poll may
have something new to do (DeviceSession.set): it checks that contract too. The device end is
the simulated study's firmware core (server/simulate/virtual_device.py) or the tests' FakeDevice.
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Callable
from typing import Protocol

from devices import messages as m
from devices.framing import FrameDecoder
from devices.link import BYTE_TIME_S


class DeviceEnd(Protocol):
    """The device's side of the line: bytes in at a time, its answer's bytes out."""

    def receive_data(self, data: bytes, now_s: float) -> None: ...

    def data_to_send(self) -> bytes: ...


class SimulatedLink:
    """A host protocol and a device on one simulated serial line."""

    def __init__(self, host, device: DeviceEnd, *, byte_time_s: float = BYTE_TIME_S, latency_s: float = 0.0,
                 to_device: Callable[[bytes], bytes] | None = None):
        self.host, self.device = host, device
        self.byte_time_s, self.latency_s = byte_time_s, latency_s
        self.to_device = to_device      # optional filter on host writes (to corrupt or drop bytes)
        self.t = 0.0
        self.writes: list[tuple[float, bytes]] = []   # every host write: (time, bytes)
        self.events: list[tuple[float, object]] = []  # every host event: (time, event)
        self.connected = False
        self._arrivals: list = []                     # heap of (time, n, "device"|"host", bytes)
        self._n = itertools.count()
        self._free = {"device": 0.0, "host": 0.0}     # when each direction's line is idle again
        self._wake: float | None = None
        self._dirty = True
        self._next = math.inf  # min(first arrival, wake) when run_until last returned: a lower bound of both

    def plug(self) -> None:
        self.connected = True
        self.host.connection_made(self.t)
        self._collect()
        self._dirty = True

    def unplug(self, reason: str = "unplugged") -> None:
        self.connected = False
        self._arrivals.clear()
        self.host.connection_lost(self.t, reason)
        self._collect()

    def set(self, message) -> None:
        # a host set() that answers False asks for no poll: we last polled before its wake_at
        # (run_until stops short of it) and received nothing since, or we are dirty anyway
        if self.host.set(message, self.t) is not False or not self.connected:
            self._dirty = True

    def run_until(self, t_end: float) -> None:
        if not self._dirty and self._next > t_end:
            # nothing set or received since, no arrival and no wake before t_end (arrivals and
            # wakes only change in the loop below): the loop would only move the time
            if t_end > self.t:
                self.t = t_end
            return
        arrivals = self._arrivals
        while True:
            if self._dirty or (self._wake is not None and self._wake <= self.t):
                self._poll()
            nxt, wake = (arrivals[0][0] if arrivals else None), self._wake
            if wake is not None and (nxt is None or wake < nxt):  # min(): an arrival first on a tie
                nxt = wake
            if nxt is None or nxt > t_end:
                self.t = max(self.t, t_end)
                self._next = math.inf if nxt is None else nxt
                return
            self.t = max(self.t, nxt)
            while arrivals and arrivals[0][0] <= self.t:
                _, _, to, data = heapq.heappop(arrivals)
                if to == "device":
                    self.device.receive_data(data, self.t)
                    reply = self.device.data_to_send()
                    if reply:
                        self._transmit("host", reply)
                else:
                    self.host.receive_data(data, self.t)
                    self._collect()
                    self._dirty = True

    def _poll(self) -> None:
        self._dirty = False
        if not self.connected:
            self._wake = None
            return
        for _ in range(100):
            data, self._wake = self.host.poll(self.t)
            self._collect()
            if not data:
                if self._wake is not None and self._wake <= self.t:
                    raise AssertionError(f"poll() returned nothing but asks to be called again at once (t={self.t})")
                return
            self.writes.append((self.t, data))
            data = self.to_device(data) if self.to_device else data
            self._transmit("device", data)
        raise AssertionError("poll() keeps returning data at one instant: the link budget is not applied")

    def _transmit(self, to: str, data: bytes) -> None:
        start = max(self.t, self._free[to])
        self._free[to] = start + len(data) * self.byte_time_s
        heapq.heappush(self._arrivals, (self._free[to] + self.latency_s, next(self._n), to, data))

    def _collect(self) -> None:
        events = self.host.events_received()
        if events:
            t = self.t
            self.events.extend([(t, e) for e in events])

    def written_messages(self) -> list[tuple[float, object]]:
        """(time, message) of every frame the host wrote, decoded again."""
        decoder, out = FrameDecoder(), []
        for t, data in self.writes:
            for frame in decoder.feed(data):
                out.append((t, m.unpack(frame.type, frame.payload)))
        return out
