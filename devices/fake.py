"""In-memory peers for tests (like h11's ConnectionPair): a device that speaks protocol v1 and a
simulated serial line between it and a host protocol, on simulated time. No ports, no sleeps.

FakeDevice follows docs/device-protocol.md §2–§3 from the device's side (IDENTIFY, PONG, ACK,
ERROR with the codes of §3, layers per channel, 0xFF = every channel), but keeps no waveform:
the portable C core (devices/firmware) and its emulators do that.
SimulatedLink moves whole writes across a line of `byte_time_s` per byte (both directions
serialised, plus a fixed latency) and polls the host exactly when its poll() asked to be
called again, after something was received, or after a set() that answers that a poll may
have something new to do (HostProtocol.set): it checks that contract too.
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Callable

from devices import messages as m
from devices.framing import FrameDecoder, FrameError, encode_frame
from devices.link import BYTE_TIME_S

FINGERTAC = m.Identify(1, 1, 0, 0, 2, m.Caps.PULSE | m.Caps.CONTINUOUS | m.Caps.TEXTURE, 235, "fingertac")
FERROVIBE = m.Identify(1, 1, 0, 0, 1, m.Caps.PULSE | m.Caps.CONTINUOUS | m.Caps.TEXTURE | m.Caps.TILT, 235,
                       "ferrovibe")
_ERROR_CODES = {"framing": m.ErrorCode.FRAMING, "too_long": m.ErrorCode.BAD_LENGTH,  # §1: too_long is code 3
                "bad_length": m.ErrorCode.BAD_LENGTH, "bad_crc": m.ErrorCode.BAD_CRC,
                "unknown_type": m.ErrorCode.UNKNOWN_TYPE, "bad_value": m.ErrorCode.BAD_VALUE}
_NEEDS_CAP = {m.SetTilt: m.Caps.TILT, m.SetTemperature: m.Caps.TEMPERATURE, m.SetFriction: m.Caps.FRICTION}


class FakeDevice:
    def __init__(self, identity: m.Identify = FINGERTAC, *, version: int = 1):
        self.identity = identity
        self.version = version      # the only protocol version it speaks
        self.silent = False         # True: reads everything, answers nothing
        self.layers: dict[tuple[int, str], object] = {}  # (channel, layer) -> SET message; absent = off
        self.received: list[tuple[float, object]] = []   # (time, message) of every command acted on
        self.errors: list[tuple[float, int]] = []         # (time, ErrorCode) sent
        self._decoder = FrameDecoder()
        self._out = bytearray()
        self._seq = 0

    def power_cycle(self) -> None:
        self.layers.clear()
        self._decoder.reset()

    def receive_data(self, data: bytes, now_s: float) -> None:
        for item in self._decoder.feed(data):
            if isinstance(item, FrameError):
                self._send(m.Error(0xFF, _ERROR_CODES[item.kind]), now_s)
                continue
            try:
                message = m.unpack(item.type, item.payload)
            except m.MessageError as exc:
                ref = 0xFF if exc.kind == "bad_length" else item.seq  # §3: seq untrusted for bad_length
                self._send(m.Error(ref, _ERROR_CODES[exc.kind]), now_s)
                continue
            self._act(message, item.seq, now_s)

    def _act(self, message, seq: int, now_s: float) -> None:
        if not message.FROM_HOST:
            self._send(m.Error(seq, m.ErrorCode.UNKNOWN_TYPE), now_s)
        elif isinstance(message, m.Hello):
            if message.version != self.version:
                self._send(m.Error(seq, m.ErrorCode.BAD_VERSION), now_s)
            else:
                self._send(self.identity, now_s)
        elif isinstance(message, m.Ping):
            self._send(m.Pong(message.token), now_s)
        elif isinstance(message, m.SetWatchdog):  # like a firmware older than the watchdog (§6)
            self._send(m.Error(seq, m.ErrorCode.UNKNOWN_TYPE), now_s)
        else:
            code = self._check(message)
            if code is not None:
                self._send(m.Error(seq, code), now_s)
                return
            self.received.append((now_s, message))
            channels = range(self.identity.channels) if message.channel == m.ALL_CHANNELS else [message.channel]
            for c in channels:
                if isinstance(message, m.Stop):
                    for layer in m.LAYERS:
                        self.layers.pop((c, layer), None)
                else:
                    self.layers[(c, message.layer_key[1])] = m.as_seen_by(message, (c, message.layer_key[1]))
            self._send(m.Ack(seq), now_s)

    def _check(self, message) -> m.ErrorCode | None:
        if message.channel != m.ALL_CHANNELS and message.channel >= self.identity.channels:
            return m.ErrorCode.BAD_CHANNEL
        need = _NEEDS_CAP.get(type(message))
        if isinstance(message, m.SetPattern) and message.mode != m.PatternMode.OFF:
            need = m.Caps(1 << (message.mode - 1))
        if need is not None and not self.identity.caps & need:
            return m.ErrorCode.UNSUPPORTED
        return None

    def layer(self, channel: int, layer: str):
        """What the channel shows on a layer; the off value (or None) when never set or stopped."""
        value = self.layers.get((channel, layer))
        return value if value is not None else m.as_seen_by(m.Stop(channel), (channel, layer))

    def _send(self, message, now_s: float) -> None:
        if isinstance(message, m.Error):
            self.errors.append((now_s, message.code))
        if self.silent:
            return
        self._out += encode_frame(message.TYPE, self._seq, message.pack())
        self._seq = (self._seq + 1) & 0xFF

    def data_to_send(self) -> bytes:
        out, self._out = bytes(self._out), bytearray()
        return out


class SimulatedLink:
    """A host protocol and a FakeDevice on one simulated serial line."""

    def __init__(self, host, device: FakeDevice, *, byte_time_s: float = BYTE_TIME_S, latency_s: float = 0.0,
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
