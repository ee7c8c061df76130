"""Messages of the device protocol v1 (docs/device-protocol.md §2 host → device, §3 device → host).

One frozen dataclass per message, fields named and ordered as in the doc's payload tables, in
the protocol's integer units (µs, centi-degrees, centi-°C, milli, %). Each class has its `TYPE`,
`pack() -> payload bytes` and `unpack(payload)`; the module-level `unpack(type, payload)`
dispatches on the type. Every field is range-checked on construction, so a bad value is a
`MessageError` (a ValueError) naming the field, whether it comes from the host's own code or
from the wire; on the wire it is classified like §1 (`unknown_type`, `bad_length`,
`bad_value`).

Layers and coalescing (§2): the four SET commands each set one layer of a channel, so only the
newest value per `layer_key` = (channel, layer) matters. STOP is kept as a command of its own
with the key (channel, "stop"): it sets *every* layer of the channel (or of every channel for
0xFF) at once, see `overrides`, `touches` and `as_seen_by` for what that means to older and
newer commands. The human-unit constructors (`SetPattern.pulse`, `SetTilt.from_degrees`, ...)
round half up to the protocol's integer units, like the firmware's own arithmetic would.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass, fields, replace
from enum import IntEnum, IntFlag
from typing import ClassVar

from server.core.numbers import is_finite_number

PROTOCOL_VERSION = 1
ALL_CHANNELS = 0xFF
MAX_ON_OFF_US = 60_000_000
LAYERS = ("pattern", "tilt", "temperature", "friction")
STOP_LAYER = "stop"  # the layer name of Stop's layer_key: every layer of the channel

U8, U16, U32 = (0, 0xFF), (0, 0xFFFF), (0, 0xFFFF_FFFF)


class PatternMode(IntEnum):
    OFF = 0
    PULSE = 1
    CONTINUOUS = 2
    TEXTURE = 3


_PATTERN_MODES = tuple(PatternMode)  # by value: 0, 1, 2, 3


class Caps(IntFlag):
    PULSE = 1 << 0
    CONTINUOUS = 1 << 1
    TEXTURE = 1 << 2
    TILT = 1 << 3
    TEMPERATURE = 1 << 4
    FRICTION = 1 << 5


CAP_NAMES = tuple(cap.name.lower() for cap in Caps)  # in bit order: pulse, continuous, ...


def cap_names(bits: int) -> frozenset[str]:
    """IDENTIFY's caps byte as names."""
    return frozenset(name for bit, name in enumerate(CAP_NAMES) if bits >> bit & 1)


class ErrorCode(IntEnum):
    BAD_CRC = 1
    FRAMING = 2
    BAD_LENGTH = 3
    UNKNOWN_TYPE = 4
    BAD_VALUE = 5
    UNSUPPORTED = 6
    BAD_CHANNEL = 7
    BAD_VERSION = 8


# §3: for these the device could not read the frame, so ref_seq (0xFF) names no command.
UNTRUSTED_SEQ_CODES = frozenset({ErrorCode.BAD_CRC, ErrorCode.FRAMING, ErrorCode.BAD_LENGTH})


class MessageError(ValueError):
    """A payload or field the protocol does not allow. kind: unknown_type | bad_length | bad_value."""

    def __init__(self, kind: str, message: str, field: str | None = None):
        super().__init__(message)
        self.kind = kind
        self.field = field


_EXACT_INT = 2**52  # an int below this in size and int + 0.5 are exact as floats


def _round_half_up(value: float, field: str) -> int:
    if type(value) is float and -math.inf < value < math.inf:  # finite (NaN fails the compare)
        return math.floor(value + 0.5)
    if type(value) is int and -_EXACT_INT < value < _EXACT_INT:  # floor(value + 0.5) is value itself
        return value
    if not is_finite_number(value):
        raise MessageError("bad_value", f"{field} must be a finite number, got {value!r}", field)
    return math.floor(value + 0.5)


_FIELD_NAMES: dict[type, tuple[str, ...]] = {}  # message class -> its field names, in order


def _field_names(cls: type) -> tuple[str, ...]:
    names = _FIELD_NAMES.get(cls)
    if names is None:  # a class's fields never change: look them up once
        names = _FIELD_NAMES[cls] = tuple(f.name for f in fields(cls))
    return names


class _Message:
    TYPE: ClassVar[int]
    FORMAT: ClassVar[str]  # struct format of the fixed payload
    RANGES: ClassVar[dict[str, tuple[int, int]]]
    FROM_HOST: ClassVar[bool]

    def __post_init__(self) -> None:
        for name, (low, high) in self.RANGES.items():
            value = getattr(self, name)
            if type(value) is int and low <= value <= high:
                continue  # a plain int in range: the check below would pass it
            if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
                raise MessageError("bad_value", f"{type(self).__name__}.{name} must be an integer in "
                                   f"[{low}, {high}], got {value!r}", name)

    @classmethod
    def _unchecked(cls, values: tuple):
        """The instance cls(*values) builds, for values its __post_init__ passes unchanged (plain
        ints in range, enum members where it converts): fields set in order, as the dataclass
        __init__ sets them, without the check."""
        message = object.__new__(cls)
        message.__dict__.update(zip(_field_names(cls), values))
        return message

    def _values(self) -> tuple:
        return tuple([getattr(self, name) for name in _field_names(type(self))])

    def pack(self) -> bytes:
        return struct.pack(self.FORMAT, *self._values())

    @classmethod
    def unpack(cls, payload: bytes):
        size = struct.calcsize(cls.FORMAT)
        if len(payload) != size:
            raise MessageError("bad_length", f"{cls.__name__} payload is {size} bytes, got {len(payload)}")
        return cls(*struct.unpack(cls.FORMAT, payload))


# ---- host → device (§2) --------------------------------------------------------------------

@dataclass(frozen=True)
class Hello(_Message):
    TYPE: ClassVar = 0x01
    FORMAT: ClassVar = "<B"
    RANGES: ClassVar = {"version": U8}
    FROM_HOST: ClassVar = True
    version: int = PROTOCOL_VERSION  # protocol version the host speaks (§6)


@dataclass(frozen=True)
class Ping(_Message):
    TYPE: ClassVar = 0x02
    FORMAT: ClassVar = "<I"
    RANGES: ClassVar = {"token": U32}
    FROM_HOST: ClassVar = True
    token: int  # echoed in PONG


WATCHDOG_MIN_MS, WATCHDOG_MAX_MS = 10, 60_000


@dataclass(frozen=True)
class SetWatchdog(_Message):
    """Every actuator off when no valid frame arrives for timeout_ms (0 = off); answered by ACK,
    by ERROR unknown_type from a firmware that predates it (§2, §6)."""
    TYPE: ClassVar = 0x03
    FORMAT: ClassVar = "<H"
    RANGES: ClassVar = {"timeout_ms": (0, WATCHDOG_MAX_MS)}
    FROM_HOST: ClassVar = True
    timeout_ms: int

    def __post_init__(self) -> None:
        super().__post_init__()
        if 0 < self.timeout_ms < WATCHDOG_MIN_MS:
            raise MessageError("bad_value", f"SetWatchdog.timeout_ms must be 0 or {WATCHDOG_MIN_MS}.."
                               f"{WATCHDOG_MAX_MS}, got {self.timeout_ms}", "timeout_ms")


@dataclass(frozen=True)
class SetPattern(_Message):
    """The pattern layer: off, pulse train, continuous vibration or texture (§2 mode)."""
    TYPE: ClassVar = 0x10
    FORMAT: ClassVar = "<BBBHII"
    RANGES: ClassVar = {"channel": U8, "mode": (0, 3), "intensity": (0, 100), "carrier_hz": U16,
                        "on_us": (0, MAX_ON_OFF_US), "off_us": (0, MAX_ON_OFF_US)}
    FROM_HOST: ClassVar = True
    channel: int     # 0..channels-1, 0xFF = every channel
    mode: int        # PatternMode
    intensity: int   # % (0..100)
    carrier_hz: int  # Hz; 0 = the device's own carrier
    on_us: int       # µs of vibration (pulse) / actuator on (texture); 0 = always off
    off_us: int      # µs of silence; 0 with on_us > 0 = always on

    def __post_init__(self) -> None:
        _Message.__post_init__(self)  # super()'s, without building a super object per message
        object.__setattr__(self, "mode", _PATTERN_MODES[self.mode])  # PatternMode(mode); mode is in range

    @property
    def layer_key(self) -> tuple[int, str]:
        return (self.channel, "pattern")

    @property
    def on_ms(self) -> float:
        return self.on_us / 1000

    @property
    def off_ms(self) -> float:
        return self.off_us / 1000

    @property
    def period_us(self) -> int:
        return self.on_us + self.off_us

    @classmethod
    def off(cls, channel: int = ALL_CHANNELS) -> SetPattern:
        return cls(channel, PatternMode.OFF, 0, 0, 0, 0)

    @classmethod
    def pulse(cls, channel: int, t_on_ms: float, t_off_ms: float, intensity_pct: float,
              carrier_hz: float = 0, *, in_range: bool = False) -> SetPattern:
        """`in_range`: the caller vouches that every field comes out in range, as from a checked
        cues.PulseTrain (0..60000 ms, 0..100 %, carrier 0 or 1..2000 Hz) on channel 0..255; the
        message is then not checked again."""
        values = (channel, PatternMode.PULSE, _round_half_up(intensity_pct, "intensity"),
                  _round_half_up(carrier_hz, "carrier_hz"), _round_half_up(t_on_ms * 1000, "on_us"),
                  _round_half_up(t_off_ms * 1000, "off_us"))
        return cls._unchecked(values) if in_range else cls(*values)

    @classmethod
    def continuous(cls, channel: int, intensity_pct: float, carrier_hz: float = 0) -> SetPattern:
        # on_us, off_us are ignored in this mode and must be sent as 0 (§2)
        return cls(channel, PatternMode.CONTINUOUS, _round_half_up(intensity_pct, "intensity"),
                   _round_half_up(carrier_hz, "carrier_hz"), 0, 0)

    @classmethod
    def texture(cls, channel: int, period_us: float, duty: float, intensity_pct: float) -> SetPattern:
        """On for duty·P, off for the rest; no carrier (the switching is the vibration, §2)."""
        if not (is_finite_number(duty) and 0.0 <= duty <= 1.0):
            raise MessageError("bad_value", f"duty must be in [0, 1], got {duty!r}", "duty")
        period = _round_half_up(period_us, "period_us")
        on_us = _round_half_up(duty * period, "on_us")
        return cls(channel, PatternMode.TEXTURE, _round_half_up(intensity_pct, "intensity"), 0, on_us, period - on_us)


@dataclass(frozen=True)
class SetTilt(_Message):
    TYPE: ClassVar = 0x11
    FORMAT: ClassVar = "<BHB"
    RANGES: ClassVar = {"channel": U8, "direction_cdeg": (0, 35_999), "magnitude": (0, 100)}
    FROM_HOST: ClassVar = True
    channel: int
    direction_cdeg: int  # centi-degrees: 0 front of the fingerpad, 9000 right, 18000 back, 27000 left
    magnitude: int       # % (0 = flat)

    @property
    def layer_key(self) -> tuple[int, str]:
        return (self.channel, "tilt")

    @property
    def direction_deg(self) -> float:
        return self.direction_cdeg / 100

    @classmethod
    def from_degrees(cls, channel: int, direction_deg: float, magnitude_pct: float) -> SetTilt:
        # % 36000 after rounding: 359.996° rounds to 36000 cdeg, which is 0°
        return cls(channel, _round_half_up(direction_deg * 100, "direction_cdeg") % 36_000,
                   _round_half_up(magnitude_pct, "magnitude"))

    @classmethod
    def flat(cls, channel: int = ALL_CHANNELS) -> SetTilt:
        return cls(channel, 0, 0)


@dataclass(frozen=True)
class SetTemperature(_Message):
    TYPE: ClassVar = 0x12
    FORMAT: ClassVar = "<Bh"
    RANGES: ClassVar = {"channel": U8, "centi_celsius": (0, 5000)}
    FROM_HOST: ClassVar = True
    channel: int
    centi_celsius: int  # °C × 100

    @property
    def layer_key(self) -> tuple[int, str]:
        return (self.channel, "temperature")

    @property
    def celsius(self) -> float:
        return self.centi_celsius / 100

    @classmethod
    def from_celsius(cls, channel: int, celsius: float) -> SetTemperature:
        return cls(channel, _round_half_up(celsius * 100, "centi_celsius"))


@dataclass(frozen=True)
class SetFriction(_Message):
    TYPE: ClassVar = 0x13
    FORMAT: ClassVar = "<BH"
    RANGES: ClassVar = {"channel": U8, "milli": (0, 5000)}
    FROM_HOST: ClassVar = True
    channel: int
    milli: int  # friction coefficient × 1000

    @property
    def layer_key(self) -> tuple[int, str]:
        return (self.channel, "friction")

    @property
    def coefficient(self) -> float:
        return self.milli / 1000

    @classmethod
    def from_coefficient(cls, channel: int, coefficient: float) -> SetFriction:
        return cls(channel, _round_half_up(coefficient * 1000, "milli"))


@dataclass(frozen=True)
class Stop(_Message):
    """Every layer of the channel off: pattern off, tilt flat, temperature and friction off (§2)."""
    TYPE: ClassVar = 0x1F
    FORMAT: ClassVar = "<B"
    RANGES: ClassVar = {"channel": U8}
    FROM_HOST: ClassVar = True
    channel: int = ALL_CHANNELS

    @property
    def layer_key(self) -> tuple[int, str]:
        return (self.channel, STOP_LAYER)


# ---- device → host (§3) --------------------------------------------------------------------

@dataclass(frozen=True)
class Identify(_Message):
    TYPE: ClassVar = 0x81
    FORMAT: ClassVar = "<BBBBBBHB"  # followed by model_len ASCII bytes
    RANGES: ClassVar = {"version": U8, "fw_major": U8, "fw_minor": U8, "fw_patch": U8, "channels": (1, 0xFE),
                        "caps": U8, "carrier_hz": U16}
    FROM_HOST: ClassVar = False
    version: int      # protocol version the device speaks (§6)
    fw_major: int
    fw_minor: int
    fw_patch: int
    channels: int     # 1..254 (0xFF means "every channel" in commands)
    caps: int         # Caps bits; unknown bits are kept (new caps keep the version, §6)
    carrier_hz: int   # the device's own carrier, used when SET_PATTERN says 0
    model: str        # 1..32 lower-case printable ASCII, e.g. "fingertac"

    def __post_init__(self) -> None:
        super().__post_init__()
        model = self.model
        if not (isinstance(model, str) and 1 <= len(model) <= 32 and model.isascii() and model.isprintable()
                and model == model.lower()):
            raise MessageError("bad_value", f"Identify.model must be 1..32 lower-case ASCII characters, "
                               f"got {model!r}", "model")
        object.__setattr__(self, "caps", Caps(self.caps))

    @property
    def firmware(self) -> str:
        return f"{self.fw_major}.{self.fw_minor}.{self.fw_patch}"

    def pack(self) -> bytes:
        model = self.model.encode("ascii")
        return struct.pack(self.FORMAT, *self._values()[:-1], len(model)) + model

    @classmethod
    def unpack(cls, payload: bytes) -> Identify:
        head = struct.calcsize(cls.FORMAT)
        if len(payload) < head or len(payload) != head + payload[head - 1]:
            raise MessageError("bad_length", f"Identify payload is {head} bytes + model_len, got {len(payload)}")
        *numbers, _model_len = struct.unpack(cls.FORMAT, payload[:head])
        return cls(*numbers, payload[head:].decode("ascii", errors="replace"))


@dataclass(frozen=True)
class Pong(_Message):
    TYPE: ClassVar = 0x82
    FORMAT: ClassVar = "<I"
    RANGES: ClassVar = {"token": U32}
    FROM_HOST: ClassVar = False
    token: int  # the PING's token


@dataclass(frozen=True)
class Ack(_Message):
    TYPE: ClassVar = 0x83
    FORMAT: ClassVar = "<B"
    RANGES: ClassVar = {"ref_seq": U8}
    FROM_HOST: ClassVar = False
    ref_seq: int  # seq of the host frame it answers


@dataclass(frozen=True)
class Error(_Message):
    TYPE: ClassVar = 0x84
    FORMAT: ClassVar = "<BB"
    RANGES: ClassVar = {"ref_seq": U8, "code": U8}
    FROM_HOST: ClassVar = False
    ref_seq: int  # seq of the host frame it answers; 0xFF when it could not be read (§3)
    code: int     # ErrorCode; codes a newer firmware adds stay plain ints

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.code in ErrorCode._value2member_map_:
            object.__setattr__(self, "code", ErrorCode(self.code))

    @property
    def code_name(self) -> str:
        return self.code.name.lower() if isinstance(self.code, ErrorCode) else f"code_{self.code}"


@dataclass(frozen=True)
class WatchdogTripped(_Message):
    """The watchdog turned every actuator off since the last report; sent before the reply to the
    next frame, only to a host that sent SET_WATCHDOG (§3)."""
    TYPE: ClassVar = 0x85
    FORMAT: ClassVar = "<HH"
    RANGES: ClassVar = {"timeout_ms": U16, "trips": U16}
    FROM_HOST: ClassVar = False
    timeout_ms: int  # the timeout that expired
    trips: int       # since power-up (saturates at 65535)


Message = (Hello | Ping | SetWatchdog | SetPattern | SetTilt | SetTemperature | SetFriction | Stop | Identify | Pong
           | Ack | Error | WatchdogTripped)
SetMessage = SetPattern | SetTilt | SetTemperature | SetFriction | Stop
SET_MESSAGES = (SetPattern, SetTilt, SetTemperature, SetFriction, Stop)
MESSAGE_TYPES: dict[int, type] = {cls.TYPE: cls for cls in (Hello, Ping, SetWatchdog, SetPattern, SetTilt,
                                                            SetTemperature, SetFriction, Stop, Identify, Pong, Ack,
                                                            Error, WatchdogTripped)}


def unpack(type: int, payload: bytes) -> Message:
    """The message in a frame; MessageError(kind unknown_type | bad_length | bad_value) otherwise.

    Types are looked up in both tables (§2 and §3), so both peers classify a frame alike; a
    receiver that gets a type meant for the other direction decides itself what that is."""
    cls = MESSAGE_TYPES.get(type)
    if cls is None:
        raise MessageError("unknown_type", f"unknown message type {type:#04x}")
    return cls.unpack(bytes(payload))


# ---- layer semantics for coalescing (§2 "a layer keeps its value until it is set again") ----

def _covers_channel(newer: int, older: int) -> bool:
    return newer == ALL_CHANNELS or newer == older


def overrides(newer: tuple[int, str], older: tuple[int, str]) -> bool:
    """A command on `newer` sets everything a command on `older` set, so the older one no longer
    matters: same or broader channel (0xFF), and same layer or a STOP."""
    return _covers_channel(newer[0], older[0]) and (newer[1] == STOP_LAYER or newer[1] == older[1])


def touches(a: tuple[int, str], b: tuple[int, str]) -> bool:
    """Commands on a and b set some layer of some channel in common, so their order matters."""
    channels = a[0] == b[0] or ALL_CHANNELS in (a[0], b[0])
    return channels and (a[1] == b[1] or STOP_LAYER in (a[1], b[1]))


def as_seen_by(command: SetMessage, key: tuple[int, str]) -> SetMessage | None:
    """What `command` (whose key overrides `key`) left on `key`, as a message for `key`; None if
    no SET message says it (STOP's "temperature and friction off" has no SET equivalent)."""
    channel, layer = key
    if not isinstance(command, Stop):
        # messages are frozen: the command itself is what a copy on its own channel would be
        return command if command.channel == channel else replace(command, channel=channel)
    if layer == STOP_LAYER:
        return Stop(channel)
    if layer == "pattern":
        return SetPattern.off(channel)
    if layer == "tilt":
        return SetTilt.flat(channel)
    return None
