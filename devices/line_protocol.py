"""LineProtocol: DeviceSession's interface for lab firmware that speaks ASCII lines, sans-I/O.

A `LineProfile` maps each command to a line template (str.format syntax), e.g.

    pulse       = "P,{on_ms},{off_ms},{intensity}\\n"
    continuous  = "C,{intensity}\\n"
    texture     = "T,{period_us},{on_us}\\n"
    off         = "S\\n"                       # pattern mode off
    tilt        = "D,{direction_deg},{magnitude}\\n"
    temperature = "H,{celsius}\\n"
    friction    = "F,{coefficient}\\n"
    stop        = "X\\n"                       # optional, see below
    hello       = "?\\n"                       # optional handshake line
    hello_reply = "^VIESTAC"                  # optional regex a device line must match

Placeholders are the fields of the message (devices/messages.py) plus human units: on_ms,
off_ms, period_us (pattern), direction_deg (tilt), celsius (temperature), coefficient
(friction); derived values are ints when whole, so "{on_ms}" renders 50, and 1.5 when not.
Templates are checked when the profile is built: an unknown placeholder or a format that fails
is a LineProfileError naming the template and the allowed placeholders.

Behaviour, as in DeviceSession (devices/protocol.py): the same calls, latest-wins slots per
layer_key, at most one line per poll within the same LinkBudget, events out. Differences:
- no acknowledgements (a written line counts as shown), no heartbeat, no RTT, so the status is
  disconnected, handshaking or connected and never unresponsive;
- without `hello` the status is connected as soon as the port opens; with `hello` but no
  `hello_reply`, once the hello line is written; with both, when a device line matches
  (HELLO again every hello_interval_s until then);
- a command with no template is refused with a CommandRefused event, never dropped silently;
- STOP uses the `stop` template, or else the `off` line plus a flat `tilt` line (those that
  exist): temperature and friction have no off value in a template;
- every non-empty line the device sends comes out as DeviceLine(text).
"""

from __future__ import annotations

import difflib
import re
import string
from collections.abc import Mapping
from dataclasses import dataclass, fields

from devices import messages as m
from devices.framing import FrameError
from devices.link import BYTE_TIME_S, CommandBook, LinkBudget
from devices.protocol import CONNECTED, DISCONNECTED, HANDSHAKING, FrameRejected, StatusChanged

_MODE_KEYS = {m.PatternMode.OFF: "off", m.PatternMode.PULSE: "pulse", m.PatternMode.CONTINUOUS: "continuous",
              m.PatternMode.TEXTURE: "texture"}
_TEMPLATE_CLASSES = {"pulse": m.SetPattern, "continuous": m.SetPattern, "texture": m.SetPattern, "off": m.SetPattern,
                     "tilt": m.SetTilt, "temperature": m.SetTemperature, "friction": m.SetFriction, "stop": m.Stop,
                     "hello": m.Hello}
_DERIVED = {m.SetPattern: ("on_ms", "off_ms", "period_us"), m.SetTilt: ("direction_deg",),
            m.SetTemperature: ("celsius",), m.SetFriction: ("coefficient",), m.Stop: (), m.Hello: ()}
# fractional on purpose, so a format such as {on_ms:d} fails at load time, not at 1 kHz
_SAMPLES = {"pulse": m.SetPattern(0, 1, 50, 235, 1500, 2500), "continuous": m.SetPattern(0, 2, 50, 235, 0, 0),
            "texture": m.SetPattern(0, 3, 50, 0, 1250, 750), "off": m.SetPattern.off(0),
            "tilt": m.SetTilt(0, 4550, 50), "temperature": m.SetTemperature(0, 3250), "friction": m.SetFriction(0, 125),
            "stop": m.Stop(0), "hello": m.Hello()}
KEYS = (*_TEMPLATE_CLASSES, "hello_reply")
MAX_LINE = 256  # bytes of a device line before it is rejected as too_long


class LineProfileError(ValueError):
    pass


def allowed_placeholders(key: str) -> tuple[str, ...]:
    cls = _TEMPLATE_CLASSES[key]
    return (*(f.name for f in fields(cls)), *_DERIVED[cls])


def _number(value):
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return int(value) if isinstance(value, int) else value  # IntEnum / IntFlag as plain ints


def template_values(message) -> dict:
    cls = type(message)
    return {name: _number(getattr(message, name)) for name in (*(f.name for f in fields(cls)), *_DERIVED[cls])}


def _check_template(key: str, template: object) -> str:
    if not isinstance(template, str):
        raise LineProfileError(f"line template {key!r} must be a string, got {type(template).__name__}")
    if not template.isascii():
        raise LineProfileError(f"line template {key!r} must be ASCII: {template!r}")
    if not template.endswith("\n"):
        raise LineProfileError(f"line template {key!r} must end with a newline (\\n): {template!r}")
    allowed = allowed_placeholders(key)
    try:
        parsed = list(string.Formatter().parse(template))
    except ValueError as exc:
        raise LineProfileError(f"line template {key!r}: {exc} in {template!r}") from None
    for _, name, spec, _ in parsed:
        if name is None:
            continue
        if name not in allowed or (spec and "{" in spec):
            raise LineProfileError(f"line template {key!r}: unknown placeholder {{{name}}}; allowed: "
                                   + ", ".join(f"{{{a}}}" for a in allowed))
    try:
        template.format(**template_values(_SAMPLES[key]))
    except (ValueError, TypeError) as exc:
        raise LineProfileError(f"line template {key!r}: {exc} in {template!r}") from None
    return template


@dataclass(frozen=True)
class LineProfile:
    templates: Mapping[str, str]             # template key -> line template (validated)
    hello_reply: re.Pattern | None = None

    @classmethod
    def from_dict(cls, data: Mapping, *, where: str = "line") -> LineProfile:
        """From a TOML/JSON table; LineProfileError names the bad key."""
        if not isinstance(data, Mapping):
            raise LineProfileError(f"{where}: expected a table of line templates, got {type(data).__name__}")
        for key in data:
            if key not in KEYS:
                close = difflib.get_close_matches(str(key), KEYS, n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise LineProfileError(f"{where}: unknown key {key!r}{hint}; allowed: {', '.join(KEYS)}")
        try:
            templates = {k: _check_template(k, v) for k, v in data.items() if k != "hello_reply"}
        except LineProfileError as exc:
            raise LineProfileError(f"{where}: {exc}") from None
        reply = data.get("hello_reply")
        if reply is not None:
            if "hello" not in templates:
                raise LineProfileError(f"{where}: hello_reply needs a hello line to answer")
            try:
                reply = re.compile(reply)
            except (re.error, TypeError) as exc:
                raise LineProfileError(f"{where}: hello_reply is not a regular expression ({exc}): {reply!r}") from None
        if not set(templates) - {"hello"}:
            raise LineProfileError(f"{where}: no command templates; give at least one of "
                                   + ", ".join(k for k in _TEMPLATE_CLASSES if k != "hello"))
        return cls(templates, reply)

    def render(self, message) -> str | None:
        """The line(s) for a command, or None if the profile has no template for it."""
        if isinstance(message, m.Stop):
            if "stop" in self.templates:
                return self.templates["stop"].format(**template_values(message))
            parts = [self.render(m.SetPattern.off(message.channel)) if "off" in self.templates else None,
                     self.render(m.SetTilt.flat(message.channel)) if "tilt" in self.templates else None]
            return "".join(p for p in parts if p) or None
        key = _MODE_KEYS[message.mode] if isinstance(message, m.SetPattern) else {
            m.SetTilt: "tilt", m.SetTemperature: "temperature", m.SetFriction: "friction"}.get(type(message))
        template = self.templates.get(key)
        return None if template is None else template.format(**template_values(message))


@dataclass(frozen=True)
class DeviceLine:
    text: str  # one line from the device, without its line ending


@dataclass(frozen=True)
class CommandRefused:
    message: object
    reason: str


class LineProtocol:
    def __init__(self, profile: LineProfile | Mapping, *, share: float = 0.5, byte_time_s: float = BYTE_TIME_S,
                 hello_interval_s: float = 0.25, ping_interval_s: float = 0.5, silence_timeout_s: float = 1.5):
        # ping_interval_s and silence_timeout_s: accepted for DeviceSession's signature; an ASCII
        # firmware has no heartbeat this class could rely on
        self.profile = profile if isinstance(profile, LineProfile) else LineProfile.from_dict(profile)
        self.hello_interval_s = hello_interval_s
        self.status = DISCONNECTED
        self.identity = None
        self.rtt_s = None
        self.counters: dict[str, int] = dict.fromkeys(
            ("frames_in", "frames_out", "bytes_out", "acks", "device_errors", "refused", "too_long"), 0)
        self.budget = LinkBudget(share, byte_time_s)
        self.book = CommandBook()
        self._events: list = []
        self._buf = bytearray()
        self._discarding = False
        self._hello_due: float | None = None

    def connection_made(self, now_s: float) -> None:
        self._buf.clear()
        self._discarding = False
        self.book.requeue_all()
        if "hello" in self.profile.templates:
            self._hello_due = now_s
            self._set_status(HANDSHAKING, "port opened")
        else:
            self._set_status(CONNECTED, "port opened (no handshake configured)")

    def connection_lost(self, now_s: float, reason: str) -> None:
        self._hello_due = None
        self._set_status(DISCONNECTED, reason)

    def receive_data(self, data: bytes, now_s: float) -> None:
        if self.status == DISCONNECTED:
            return
        data = bytes(data)
        start = 0
        while start < len(data):
            end = data.find(b"\n", start)
            chunk = data[start:] if end < 0 else data[start:end]
            if not self._discarding:
                self._buf += chunk
                if len(self._buf) > MAX_LINE:
                    self.counters["too_long"] += 1
                    self._events.append(FrameRejected(FrameError("too_long", bytes(self._buf[:MAX_LINE]),
                                                                 f"device line longer than {MAX_LINE} bytes")))
                    self._buf.clear()
                    self._discarding = True
            if end < 0:
                break
            if not self._discarding:
                self._line(self._buf.decode("ascii", errors="replace").rstrip("\r"))
            self._buf.clear()
            self._discarding = False
            start = end + 1

    def _line(self, text: str) -> None:
        if not text:
            return
        self.counters["frames_in"] += 1
        self._events.append(DeviceLine(text))
        reply = self.profile.hello_reply
        if self.status == HANDSHAKING and reply is not None and reply.search(text):
            self._hello_due = None
            self._set_status(CONNECTED, f"device answered {text!r}")

    def set(self, message, now_s: float) -> None:
        if not isinstance(message, m.SET_MESSAGES):
            raise TypeError(f"not a SET_* or STOP message: {message!r}")
        if self.profile.render(message) is None:
            self.counters["refused"] += 1
            what = (f"pattern mode {_MODE_KEYS[message.mode]!r}" if isinstance(message, m.SetPattern)
                    else type(message).__name__)
            self._events.append(CommandRefused(message, f"the line profile has no template for {what}"))
            return
        self.book.set(message, now_s)

    def poll(self, now_s: float) -> tuple[bytes, float | None]:
        if self.status == DISCONNECTED:
            return b"", None
        data = self.budget.write(now_s, lambda: self._next_write(now_s))
        self.counters["bytes_out"] += len(data)
        self.counters["frames_out"] += bool(data)
        due = [t for t in (self._hello_due, -float("inf") if self.book.pending else None) if t is not None]
        return data, (max(min(due), self.budget.ready_at, now_s) if due else None)

    def _next_write(self, now_s: float) -> bytes:
        if self._hello_due is not None and self._hello_due <= now_s:
            if self.profile.hello_reply is None:
                self._hello_due = None
                self._set_status(CONNECTED, "hello written (no reply configured)")
            else:
                self._hello_due = now_s + self.hello_interval_s
            return self.profile.templates["hello"].format(**template_values(m.Hello())).encode("ascii")
        nxt = self.book.pop_next()
        if nxt is None:
            return b""
        key, message, since = nxt
        self.book.mark_written(key, message, since, now_s)  # no ACKs on a line link: written = shown
        return self.profile.render(message).encode("ascii")

    def events_received(self) -> list:
        events, self._events = self._events, []
        return events

    def _set_status(self, new: str, reason: str) -> None:
        if new != self.status:
            old, self.status = self.status, new
            self._events.append(StatusChanged(old, new, reason))
