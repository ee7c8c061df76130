"""Frames of the device protocol (docs/device-protocol.md §1): COBS(body ‖ crc16 LE) ‖ 0x00.

Theory of operation. `encode_frame` builds one complete wire frame. `FrameDecoder` is a
streaming receiver: bytes go in through `feed` in any chunking, and out come, in order, the
frames whose CRC is good (`Frame`) and one `FrameError` per rejected frame. 0x00 is the only
delimiter COBS leaves on the wire, so after any garbage the decoder resynchronises at the next
0x00. It never raises on input: a misbehaving peer is a counted error, not a crash.

What is *in* a frame (known type, payload length, ranges) is devices/messages.py's business;
this module only checks the frame itself: COBS, size and CRC.
"""

from __future__ import annotations

import binascii
from dataclasses import dataclass

from cobs import cobs

MAX_PAYLOAD = 58   # body 2..60 bytes (§1 Sizes)
MAX_DECODED = 62   # body + CRC
MIN_DECODED = 4    # type, seq, CRC
MAX_WIRE = 64      # bytes a receiver buffers before a delimiter (§1 table: too_long)

# Rejection kinds of §1, with the ERROR code a device answers them with (too_long shares 3).
FRAMING, TOO_LONG, BAD_LENGTH, BAD_CRC = "framing", "too_long", "bad_length", "bad_crc"


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection, no final XOR), §1."""
    return binascii.crc_hqx(data, 0xFFFF)


@dataclass(frozen=True)
class Frame:
    """A frame with a good CRC; its type and payload are not checked yet."""
    type: int       # message type, u8 (§2, §3)
    seq: int        # sender's sequence number, u8
    payload: bytes  # 0..58 bytes


@dataclass(frozen=True)
class FrameError:
    """A rejected frame: kind is one of framing, too_long, bad_length, bad_crc (§1), or, from
    the message layer, unknown_type / bad_length / bad_value."""
    kind: str
    data: bytes = b""  # the offending bytes as received (at most MAX_WIRE), for the log
    detail: str = ""


def encode_frame(type: int, seq: int, payload: bytes = b"") -> bytes:
    """The complete wire frame, including the trailing 0x00 delimiter."""
    if not (0 <= type <= 0xFF and 0 <= seq <= 0xFF):
        raise ValueError(f"type and seq are u8, got type={type!r} seq={seq!r}")
    if len(payload) > MAX_PAYLOAD:
        raise ValueError(f"payload is at most {MAX_PAYLOAD} bytes, got {len(payload)}")
    body = bytes((type, seq)) + bytes(payload)
    return cobs.encode(body + crc16(body).to_bytes(2, "little")) + b"\x00"


def decode_frame(encoded: bytes) -> Frame | FrameError:
    """One frame without its delimiter (non-empty, no 0x00 inside)."""
    try:
        raw = cobs.decode(encoded)
    except cobs.DecodeError as exc:  # a code byte points past the end (§1 framing)
        return FrameError(FRAMING, bytes(encoded), str(exc))
    if not MIN_DECODED <= len(raw) <= MAX_DECODED:
        return FrameError(BAD_LENGTH, bytes(encoded), f"decoded frame of {len(raw)} bytes")
    body, crc = raw[:-2], int.from_bytes(raw[-2:], "little")
    if crc16(body) != crc:
        return FrameError(BAD_CRC, bytes(encoded), f"crc {crc:#06x} != {crc16(body):#06x}")
    return Frame(body[0], body[1], bytes(body[2:]))


_DECODED_KEPT = 1024


class FrameDecoder:
    """Streaming receiver: feed(bytes) -> frames and errors, in arrival order."""

    def __init__(self, max_wire: int = MAX_WIRE):
        self.max_wire = max_wire
        self._buf = bytearray()
        self._discarding = False  # after too_long: skip up to the next 0x00 (§1 Sizes)
        # decode_frame is pure and its results immutable, and a device's replies repeat (an ACK
        # per seq): equal bytes are decoded once (bounded: emptied when full)
        self._decoded: dict[bytes, Frame | FrameError] = {}

    def reset(self) -> None:
        """Forget a partial frame (a new port starts clean)."""
        self._buf.clear()
        self._discarding = False

    def feed(self, data: bytes) -> list[Frame | FrameError]:
        out: list[Frame | FrameError] = []
        data = bytes(data)
        start, n = 0, len(data)
        while start < n:
            end = data.find(0, start)
            chunk = data[start:] if end < 0 else data[start:end]
            if not self._discarding and chunk:
                self._buf += chunk
                if len(self._buf) > self.max_wire:
                    # "more than 64 bytes before a delimiter": report once, then wait for 0x00
                    out.append(FrameError(TOO_LONG, bytes(self._buf[:self.max_wire]),
                                          f"more than {self.max_wire} bytes before a delimiter"))
                    self._buf.clear()
                    self._discarding = True
            if end < 0:
                break
            if self._discarding:
                self._discarding = False  # resynchronised
            elif self._buf:
                encoded = bytes(self._buf)
                item = self._decoded.get(encoded)
                if item is None:
                    if len(self._decoded) >= _DECODED_KEPT:
                        self._decoded.clear()
                    item = self._decoded[encoded] = decode_frame(encoded)
                out.append(item)
            # an empty frame (0x00 0x00) is a flush, not an error (§1)
            self._buf.clear()
            start = end + 1
        return out
