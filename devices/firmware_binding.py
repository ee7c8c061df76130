"""ctypes binding of the device firmware core (devices/firmware, docs/device-protocol.md).

The device emulators run the very C code the ESP32 sketches run: `Firmware` owns one
`vt_device` (the whole device state, a plain buffer of `vt_device_sizeof()` bytes), feeds it
host bytes with explicit microsecond timestamps, and hands back its reply bytes and the
actuator *edges* (every change of a channel's output, stamped with its exact scheduled time).
Nothing here reads a clock: time is always an argument and must not go backwards.

The shared library is built on first use (`gcc` on devices/firmware/src/*.c, or whatever `CC`
names) whenever build/libviestac_fw.so is missing or older than a source or header. Builds are
serialised with a file lock and land under a temporary name that is renamed into place, so two
processes starting at once never load half a library.

The frame-level functions (`crc16`, `cobs_encode`, `cobs_decode`, `encode_frame`,
`message_check`, `FrameDecoder`) are thin wrappers for the shared test vectors.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import shutil
import subprocess
import threading
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

try:
    import fcntl
except ImportError:  # Windows: no lock; the atomic rename still keeps the library whole
    fcntl = None

from devices.messages import CAP_NAMES, cap_names

FIRMWARE_DIR = Path(__file__).resolve().parent / "firmware"
BUILD_DIR = FIRMWARE_DIR / "build"
LIBRARY_PATH = BUILD_DIR / "libviestac_fw.so"

MODELS = ("fingertac", "ferrovibe", "devkit")
MAX_PAYLOAD = 58
MAX_CHANNELS = 4
NEVER = 2**64 - 1
CAUSES = {0: "state", 1: "command", 2: "schedule", 3: "watchdog"}
DECODE_ERRORS = {2: "framing", 3: "too_long", 4: "bad_length", 5: "bad_crc"}
CHECK_ERRORS = {0: None, 3: "bad_length", 4: "unknown_type"}


class FirmwareBuildError(RuntimeError):
    """The C core could not be built (no compiler, or a compile error)."""


# ---- building -----------------------------------------------------------------------------------

def _sources() -> list[Path]:
    return sorted((FIRMWARE_DIR / "src").glob("*.c"))


def _stale() -> bool:
    if not LIBRARY_PATH.exists():
        return True
    built = LIBRARY_PATH.stat().st_mtime_ns
    inputs = _sources() + sorted((FIRMWARE_DIR / "include").glob("*.h"))
    return any(p.stat().st_mtime_ns > built for p in inputs)


@contextlib.contextmanager
def _build_lock() -> Iterator[None]:
    BUILD_DIR.mkdir(parents=True, exist_ok=True)
    with open(BUILD_DIR / ".build.lock", "w") as handle:
        if fcntl is not None:
            fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            if fcntl is not None:
                fcntl.flock(handle, fcntl.LOCK_UN)


def _compiler() -> str:
    for candidate in (os.environ.get("CC"), "gcc", "cc", "clang"):
        if candidate and shutil.which(candidate):
            return candidate
    raise FirmwareBuildError(
        f"cannot build {LIBRARY_PATH}: no C compiler found (tried $CC, gcc, cc, clang). Install gcc "
        "(e.g. `apt-get install gcc`) or build it elsewhere with `make -C devices/firmware lib`.")


def build_library(force: bool = False) -> Path:
    """Build build/libviestac_fw.so if it is missing or out of date; returns its path."""
    if not force and not _stale():
        return LIBRARY_PATH
    with _build_lock():
        if not force and not _stale():      # another process built it while we waited
            return LIBRARY_PATH
        try:
            compiler = _compiler()
        except FirmwareBuildError as exc:
            if force or not LIBRARY_PATH.exists():
                raise
            # e.g. an image that ships a prebuilt library but no compiler, with fresh mtimes
            warnings.warn(f"{exc} Using the existing, possibly outdated, library.", RuntimeWarning, stacklevel=2)
            return LIBRARY_PATH
        tmp = BUILD_DIR / f"libviestac_fw.so.tmp.{os.getpid()}"
        cmd = [compiler, "-std=c99", "-Wall", "-Wextra", "-O2", "-fPIC", "-shared",
               f"-I{FIRMWARE_DIR / 'include'}", "-o", str(tmp), *map(str, _sources())]
        try:
            result = subprocess.run(cmd, capture_output=True, text=True)
        except OSError as exc:
            raise FirmwareBuildError(f"cannot run {cmd[0]}: {exc}") from exc
        if result.returncode != 0:
            tmp.unlink(missing_ok=True)
            raise FirmwareBuildError(f"building the firmware core failed:\n$ {' '.join(cmd)}\n"
                                     f"{result.stdout}{result.stderr}")
        os.replace(tmp, LIBRARY_PATH)
    return LIBRARY_PATH


def ensure_library() -> Path:
    """Build the library now if needed (e.g. once before starting several emulator processes)."""
    return build_library()


# ---- C types (mirror include/viestac_fw.h; sizes are checked against the library) ----------------

class _Model(ctypes.Structure):
    _fields_ = [("name", ctypes.c_char_p), ("fw_major", ctypes.c_uint8), ("fw_minor", ctypes.c_uint8),
                ("fw_patch", ctypes.c_uint8), ("channels", ctypes.c_uint8), ("caps", ctypes.c_uint8),
                ("carrier_hz", ctypes.c_uint16)]


class _Edge(ctypes.Structure):
    _fields_ = [("t_us", ctypes.c_uint64), ("channel", ctypes.c_uint8), ("gate", ctypes.c_uint8),
                ("mode", ctypes.c_uint8), ("intensity", ctypes.c_uint8), ("carrier_hz", ctypes.c_uint16),
                ("direction_cdeg", ctypes.c_uint16), ("centi_celsius", ctypes.c_int16),
                ("friction_milli", ctypes.c_uint16), ("magnitude", ctypes.c_uint8),
                ("temperature_on", ctypes.c_uint8), ("friction_on", ctypes.c_uint8), ("cause", ctypes.c_uint8)]


class _Channel(ctypes.Structure):
    _fields_ = [("next_us", ctypes.c_uint64), ("on_us", ctypes.c_uint32), ("off_us", ctypes.c_uint32),
                ("carrier_hz", ctypes.c_uint16), ("direction_cdeg", ctypes.c_uint16),
                ("centi_celsius", ctypes.c_int16), ("friction_milli", ctypes.c_uint16),
                ("mode", ctypes.c_uint8), ("intensity", ctypes.c_uint8), ("phase_on", ctypes.c_uint8),
                ("magnitude", ctypes.c_uint8), ("temperature_on", ctypes.c_uint8),
                ("friction_on", ctypes.c_uint8), ("last", _Edge)]


class _Frame(ctypes.Structure):
    _fields_ = [("type", ctypes.c_uint8), ("seq", ctypes.c_uint8), ("len", ctypes.c_uint8),
                ("payload", ctypes.c_uint8 * MAX_PAYLOAD)]


class _Decoder(ctypes.Structure):
    _fields_ = [("buf", ctypes.c_uint8 * 64), ("len", ctypes.c_uint8), ("discarding", ctypes.c_uint8)]


_lib_handle: ctypes.CDLL | None = None
_lib_lock = threading.Lock()


def _lib() -> ctypes.CDLL:
    global _lib_handle
    with _lib_lock:
        if _lib_handle is None:
            _lib_handle = _load(build_library())
        return _lib_handle


def _load(path: Path) -> ctypes.CDLL:
    lib = ctypes.CDLL(str(path))
    u8p, vp, sz, u64 = ctypes.c_char_p, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_uint64
    sigs = {
        "vt_crc16": (ctypes.c_uint16, [u8p, sz]),
        "vt_cobs_encode": (sz, [u8p, sz, u8p]),
        "vt_cobs_decode": (ctypes.c_int, [u8p, sz, u8p, sz, ctypes.POINTER(sz)]),
        "vt_frame_encode": (sz, [ctypes.c_uint8, ctypes.c_uint8, u8p, sz, u8p, sz]),
        "vt_decoder_init": (None, [vp]),
        "vt_decoder_feed": (ctypes.c_int, [vp, ctypes.c_uint8, ctypes.POINTER(_Frame)]),
        "vt_message_check": (ctypes.c_int, [ctypes.c_uint8, u8p, sz]),
        "vt_model_by_name": (ctypes.POINTER(_Model), [ctypes.c_char_p]),
        "vt_device_sizeof": (sz, []),
        "vt_edge_sizeof": (sz, []),
        "vt_channel_sizeof": (sz, []),
        "vt_edge_offset": (sz, [ctypes.c_int]),
        "vt_device_init": (ctypes.c_int, [vp, ctypes.POINTER(_Model)]),
        "vt_device_receive": (None, [vp, u8p, sz, u64]),
        "vt_device_take_output": (sz, [vp, u8p, sz]),
        "vt_device_advance": (sz, [vp, u64, ctypes.POINTER(_Edge), sz]),
        "vt_device_next_edge_us": (u64, [vp]),
        "vt_device_watchdog_deadline_us": (u64, [vp]),
        "vt_device_channel": (ctypes.POINTER(_Channel), [vp, ctypes.c_uint8]),
        "vt_device_counter": (ctypes.c_uint32, [vp, ctypes.c_int]),
        "vt_counter_name": (ctypes.c_char_p, [ctypes.c_int]),
    }
    for name, (restype, argtypes) in sigs.items():
        try:
            fn = getattr(lib, name)
        except AttributeError:
            raise FirmwareBuildError(f"{path} has no {name}: it is older than devices/firmware_binding.py; rebuild it") from None
        fn.restype, fn.argtypes = restype, argtypes
    # a struct can change and keep its size (padding), so every vt_edge field's offset is compared too
    offsets = [getattr(_Edge, name).offset for name, _ in _Edge._fields_] + [ctypes.c_size_t(-1).value]
    if (lib.vt_edge_sizeof() != ctypes.sizeof(_Edge) or lib.vt_channel_sizeof() != ctypes.sizeof(_Channel)
            or [lib.vt_edge_offset(k) for k in range(len(offsets))] != offsets):
        raise FirmwareBuildError(f"{path} does not match devices/firmware_binding.py's struct layout; rebuild it")
    return lib


# ---- frame-level wrappers -----------------------------------------------------------------------

def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE (§1)."""
    data = bytes(data)
    return _lib().vt_crc16(data, len(data))


def cobs_encode(raw: bytes) -> bytes:
    """COBS without the trailing delimiter."""
    raw = bytes(raw)
    out = ctypes.create_string_buffer(len(raw) + len(raw) // 254 + 2)
    n = _lib().vt_cobs_encode(raw, len(raw), out)
    return out.raw[:n]


def cobs_decode(encoded: bytes) -> bytes:
    """Inverse of cobs_encode; ValueError if `encoded` is not valid COBS."""
    encoded = bytes(encoded)
    out = ctypes.create_string_buffer(max(len(encoded), 1))
    n = ctypes.c_size_t()
    if _lib().vt_cobs_decode(encoded, len(encoded), out, len(out), ctypes.byref(n)) != 0:
        raise ValueError(f"not valid COBS: {encoded.hex()}")
    return out.raw[:n.value]


def encode_frame(type: int, seq: int, payload: bytes = b"") -> bytes:
    """The complete wire frame, trailing 0x00 included (§1)."""
    payload = bytes(payload)
    if not (0 <= type <= 255 and 0 <= seq <= 255) or len(payload) > MAX_PAYLOAD:
        raise ValueError(f"bad frame: type {type}, seq {seq}, {len(payload)}-byte payload (max {MAX_PAYLOAD})")
    out = ctypes.create_string_buffer(64)
    n = _lib().vt_frame_encode(type, seq, payload, len(payload), out, len(out))
    return out.raw[:n]


def message_check(type: int, payload: bytes) -> str | None:
    """None if `payload` has the right length for `type`, else "unknown_type" or "bad_length"."""
    payload = bytes(payload)
    return CHECK_ERRORS[_lib().vt_message_check(type, payload, len(payload))]


@dataclass(frozen=True)
class Frame:
    type: int
    seq: int
    payload: bytes


class FrameDecoder:
    """The C streaming decoder: feed(bytes) -> decoded frames (good CRC) and error names
    ("framing", "too_long", "bad_length", "bad_crc"), in stream order."""

    def __init__(self) -> None:
        self._lib = _lib()
        self._dec = _Decoder()
        self._lib.vt_decoder_init(ctypes.byref(self._dec))

    def feed(self, data: bytes) -> list[Frame | str]:
        results: list[Frame | str] = []
        frame = _Frame()
        for byte in bytes(data):
            r = self._lib.vt_decoder_feed(ctypes.byref(self._dec), byte, ctypes.byref(frame))
            if r == 1:
                results.append(Frame(frame.type, frame.seq, bytes(frame.payload[:frame.len])))
            elif r:
                results.append(DECODE_ERRORS[r])
        return results


# ---- the device ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class Edge:
    """The output state of one channel after a change."""
    t_us: int
    channel: int
    gate: bool            # pattern gate: vibrating (pulse on-phase, continuous) / tilted (texture)
    mode: int             # 0 off, 1 pulse, 2 continuous, 3 texture
    intensity: int        # %
    carrier_hz: int       # effective carrier; 0 for texture and off
    direction_cdeg: int
    magnitude: int        # tilt %, 0 = flat
    cause: str            # "command", "schedule" or "watchdog" ("state" only from Firmware.output)
    temperature_c: float | None = None   # temperature layer, None = off
    friction: float | None = None        # friction coefficient, None = off

    @classmethod
    def _from_c(cls, e: _Edge, cause: str | None = None) -> Edge:
        return cls(e.t_us, e.channel, bool(e.gate), e.mode, e.intensity, e.carrier_hz, e.direction_cdeg,
                   e.magnitude, cause or CAUSES.get(e.cause, str(e.cause)),
                   e.centi_celsius / 100 if e.temperature_on else None,
                   e.friction_milli / 1000 if e.friction_on else None)


class Firmware:
    """One device running the C firmware core, driven with explicit µs timestamps.

    receive() applies every complete frame at `now_us` (§2 timing rule); scheduled edges that
    fell due before it are kept, so advance() always returns edges in time order."""

    _CHUNK = 16      # bytes per C call: at most 3 frames, so the C edge queue (32) never overflows
    _BATCH = 64

    def __init__(self, model: str):
        lib = _lib()
        ptr = lib.vt_model_by_name(model.encode("ascii")) if isinstance(model, str) and model.isascii() else None
        if not ptr:
            raise ValueError(f"unknown device model {model!r}; known: {', '.join(MODELS)}")
        self._setup(lib, ptr, keep=None)

    @classmethod
    def from_descriptor(cls, name: str, *, channels: int, caps: int, carrier_hz: int,
                        firmware: tuple[int, int, int] = (1, 0, 0)) -> Firmware:
        """A core for a model that is not built in (tests, new devices): same code, own descriptor."""
        if not (name and name.isascii() and name == name.lower() and len(name) <= 32):
            raise ValueError(f"model name must be 1..32 lower-case ASCII characters, got {name!r}")
        if not (1 <= channels <= MAX_CHANNELS and 0 <= caps <= 0xFF and 0 <= carrier_hz <= 0xFFFF
                and len(firmware) == 3 and all(0 <= v <= 255 for v in firmware)):
            raise ValueError(f"bad descriptor: channels {channels} (1..{MAX_CHANNELS}), caps {caps}, "
                             f"carrier {carrier_hz}, firmware {firmware}")
        name_bytes = name.encode("ascii")
        desc = _Model(name_bytes, *firmware, channels, caps, carrier_hz)
        self = cls.__new__(cls)
        self._setup(_lib(), ctypes.pointer(desc), keep=(name_bytes, desc))
        return self

    def _setup(self, lib: ctypes.CDLL, model_ptr, keep) -> None:
        self._lib = lib
        self._keep = keep                   # a custom descriptor must outlive the device
        m = model_ptr.contents
        self.model: str = m.name.decode("ascii")
        self.channels: int = m.channels
        self.caps: int = m.caps
        self.carrier_hz: int = m.carrier_hz
        self.firmware: tuple[int, int, int] = (m.fw_major, m.fw_minor, m.fw_patch)
        size = lib.vt_device_sizeof()
        self._mem = (ctypes.c_uint64 * ((size + 7) // 8))()   # 8-byte aligned, zeroed
        self._dev = ctypes.addressof(self._mem)
        if lib.vt_device_init(self._dev, model_ptr) != 0:
            raise ValueError(f"model {self.model!r} has an invalid descriptor")
        self._edges = (_Edge * self._BATCH)()
        self._out = ctypes.create_string_buffer(256)
        self._pending: list[Edge] = []
        self._now = 0
        self._quiet_until = 0  # µs: before this the C core has nothing to do (its next edge or watchdog expiry)

    def __repr__(self) -> str:
        return f"Firmware({self.model!r}, channels={self.channels}, caps=0x{self.caps:02x})"

    @property
    def cap_names(self) -> tuple[str, ...]:
        return tuple(name for name in CAP_NAMES if name in cap_names(self.caps))

    def _check_time(self, now_us: int) -> int:
        now_us = int(now_us)
        if now_us < self._now:
            raise ValueError(f"time went backwards: {now_us} µs after {self._now} µs")
        if now_us >= NEVER:
            raise ValueError(f"time out of range: {now_us}")
        self._now = now_us
        return now_us

    def _run(self, now_us: int) -> list[Edge]:
        edges: list[Edge] = []
        while True:
            n = self._lib.vt_device_advance(self._dev, now_us, self._edges, self._BATCH)
            if n:
                edges.extend(Edge._from_c(self._edges[i]) for i in range(n))
            if n < self._BATCH:
                # vt_device_advance before the next edge (vt_device_next_edge_us, which includes
                # the watchdog's expiry) changes nothing: advance() may skip the C call until then
                self._quiet_until = self._lib.vt_device_next_edge_us(self._dev)
                return edges

    def receive(self, data: bytes, now_us: int) -> None:
        """Feed bytes from the host; complete frames take effect at now_us."""
        now_us = self._check_time(now_us)
        data = bytes(data)
        if now_us >= self._quiet_until:                   # else none is due: advance() skips it too
            self._pending.extend(self._run(now_us))       # edges due before the frames act
        if data.count(0) <= 1:
            # at most one frame can end in it, so no C call can queue more than one frame's edges,
            # and chunks before its 0x00 would only be buffered: one call leaves the core as the chunks do
            self._lib.vt_device_receive(self._dev, data, len(data), now_us)
            if 0 in data:
                self._pending.extend(self._run(now_us))
            return
        for i in range(0, len(data), self._CHUNK):
            chunk = data[i:i + self._CHUNK]
            self._lib.vt_device_receive(self._dev, chunk, len(chunk), now_us)
            if 0 in chunk:  # a frame ends at a 0x00; without one the core only buffered (or rejected): no edges
                self._pending.extend(self._run(now_us))   # the command edges

    def take_output(self) -> bytes:
        """The bytes the device wants to send to the host (replies), drained."""
        parts = []
        while n := self._lib.vt_device_take_output(self._dev, self._out, len(self._out)):
            parts.append(self._out.raw[:n])
            if n < len(self._out):
                break  # it stops short of the buffer only when nothing is left
        return b"".join(parts)

    def advance(self, now_us: int) -> list[Edge]:
        """Run the scheduler up to now_us inclusive; every output change since the last call,
        in time order, each stamped with its exact time."""
        if type(now_us) is int and self._now <= now_us < self._quiet_until and not self._pending:
            # a device between edges (most 1 kHz ticks): nothing is due. _check_time would accept
            # this time as it is (an int, not backwards, below _quiet_until <= NEVER)
            self._now = now_us
            return []
        now_us = self._check_time(now_us)
        if now_us < self._quiet_until and not self._pending:
            return []
        edges, self._pending = self._pending, []
        edges.extend(self._run(now_us))
        return edges

    def next_edge_us(self) -> int | None:
        """Time of the next edge (pending or scheduled), None if nothing is scheduled."""
        if self._pending:
            return self._pending[0].t_us
        t = self._lib.vt_device_next_edge_us(self._dev)
        return None if t == NEVER else t

    def watchdog_deadline_us(self) -> int | None:
        """When the watchdog trips unless a valid frame comes first; None while disarmed."""
        t = self._lib.vt_device_watchdog_deadline_us(self._dev)
        return None if t == NEVER else t

    def output(self, channel: int) -> Edge:
        """The channel's current output state (as of the last reported edge; cause "state")."""
        return Edge._from_c(self._channel(channel).last, "state")

    def layers(self, channel: int) -> dict[str, int | None]:
        """Every layer of a channel as the device holds it (§2); temperature/friction None = off."""
        c = self._channel(channel)
        return {"mode": c.mode, "intensity": c.intensity, "carrier_hz": c.carrier_hz, "on_us": c.on_us,
                "off_us": c.off_us, "direction_cdeg": c.direction_cdeg, "magnitude": c.magnitude,
                "centi_celsius": c.centi_celsius if c.temperature_on else None,
                "milli": c.friction_milli if c.friction_on else None}

    def _channel(self, channel: int) -> _Channel:
        if not 0 <= channel < self.channels:
            raise ValueError(f"{self.model} has channels 0..{self.channels - 1}, not {channel}")
        return self._lib.vt_device_channel(self._dev, channel).contents

    def counters(self) -> dict[str, int]:
        """frames_ok, bad_crc, framing, too_long, bad_length, unknown_type, bad_value,
        unsupported, bad_channel, bad_version, ignored, replies_dropped, edges_dropped, watchdog_trips."""
        result = {}
        i = 0
        while (name := self._lib.vt_counter_name(i)) is not None:
            result[name.decode("ascii")] = self._lib.vt_device_counter(self._dev, i)
            i += 1
        return result
