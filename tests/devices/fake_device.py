"""A device that speaks protocol v1, in memory, for the protocol tests (on devices.simulated_link's
SimulatedLink).

FakeDevice follows docs/device-protocol.md §2–§3 from the device's side (IDENTIFY, PONG, ACK,
ERROR with the codes of §3, layers per channel, 0xFF = every channel), but keeps no waveform:
the portable C core (devices/firmware) and its emulators do that.
"""

from __future__ import annotations

from devices import messages as m
from devices.framing import FrameDecoder, FrameError, encode_frame

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
