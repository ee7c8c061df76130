"""DeviceSession: the host side of a device session (docs/device-protocol.md §4), sans-I/O.

Theory of operation (the websockets/h11 shape). The adapter (devices/serial_port.py) owns the
port and the clock and calls, with the current time in seconds:

    connection_made(now)          port opened: a lone 0x00 (flush) + HELLO get queued
    receive_data(data, now)       bytes read; never raises
    set(command, now) -> bool     the newest value of one layer (SET_* or STOP); False: a poll
                                  now would do nothing new (see set)
    poll(now) -> (data, wake_at)  at most one frame to write now, and when to poll again
    connection_lost(now, reason)  read/write error or port closed
    events_received()             facts since the last call (StatusChanged, Acked, ...)

Status: disconnected → handshaking (HELLO every hello_interval_s until IDENTIFY) → connected
(PING every ping_interval_s) ⇄ unresponsive (no frame for silence_timeout_s; back at the next
good frame). IDENTIFY with a version ≠ 1, or ERROR bad_version, → bad_version (§6), which only
a new connection_made leaves.

Commands wait in latest-wins slots (devices.link.CommandBook) and leave oldest-first within the
LinkBudget, which HELLO and PING frames share (§5). A command value the device already has
(written, as far as the host knows) is not written again. Every layer is made pending again
after connection_made and after unresponsive → connected (the device may have been
power-cycled, §4.4). A command the device did not acknowledge within ack_timeout_s, or the
commands in flight when the device reports a frame it could not read (ERROR with ref_seq 0xFF,
§3), are made pending again: without that, one lost frame on a Bluetooth link could leave a
vibration running. A command answered with any other ERROR is not resent (it would fail
again); the error is reported with the command it refers to.

STOP is a command with the layer_key (channel, "stop"): it replaces the waiting values of every
layer of its channel(s), and a later SET on one of them goes after it (devices.messages.overrides).

Watchdog (§2 SET_WATCHDOG, §4.3): with `watchdog_ms` > 0 the host sends SET_WATCHDOG right after
IDENTIFY (and after unresponsive → connected, the device may have been power-cycled) and then
never lets `keepalive_interval_s` pass without a frame: when nothing else went out, a PING does.
A device that then hears nothing for watchdog_ms turns every actuator off by itself. `watchdog`
says how it stands: off | pending (sent, not acknowledged) | on | unsupported (the firmware
predates it: ERROR unknown_type; no keepalives then). A WATCHDOG report from the device (it
tripped: every layer is off) makes every layer pending again.
"""

from __future__ import annotations

from dataclasses import dataclass

from devices import messages as m
from devices.framing import Frame, FrameDecoder, FrameError, encode_frame
from devices.link import BYTE_TIME_S, CommandBook, LinkBudget

DISCONNECTED, HANDSHAKING, CONNECTED, UNRESPONSIVE, BAD_VERSION = (
    "disconnected", "handshaking", "connected", "unresponsive", "bad_version")
REJECT_KINDS = ("framing", "too_long", "bad_length", "bad_crc", "unknown_type", "bad_value")
_PING_TOKENS_KEPT = 8
_UNPACKED_KEPT = 1024
# The production defaults (devices.manager.make_protocol): the device is off at most 45 ms after
# the host's last frame, so within 50 ms of the host dying, as the device host's own quiet rule
# does for a dead loop; a keepalive at least every 11.25 ms leaves 3 of them to be lost or late (a
# writer thread that stalls ~34 ms) before a healthy host trips it; 10 bytes per 11.25 ms are 7.7 %
# of a 115200-baud link (docs/device-protocol.md §5). Slower links (Bluetooth) set more per device.
WATCHDOG_MS = 45
KEEPALIVE_INTERVAL_S = WATCHDOG_MS / 4000


# ---- events: facts, in the order they happened ----------------------------------------------

@dataclass(frozen=True)
class StatusChanged:
    old: str
    new: str
    reason: str


@dataclass(frozen=True)
class Identified:
    identity: m.Identify  # a version-1 IDENTIFY (first one, or one that differs from the last)


@dataclass(frozen=True)
class Acked:
    ref_seq: int
    latency_s: float | None  # from the frame's write to its ACK; None if the seq is unknown
    message: object = None   # the command it acknowledges, if known


@dataclass(frozen=True)
class DeviceErrorReported:
    ref_seq: int
    code: int                 # messages.ErrorCode (or a plain int for codes newer than v1)
    message_repr: str | None  # the command it refers to; None if ref_seq names none (§3)


@dataclass(frozen=True)
class FrameRejected:
    error: FrameError  # kind: framing | too_long | bad_length | bad_crc | unknown_type | bad_value


@dataclass(frozen=True)
class WatchdogReported:
    trips: int  # the device's watchdog turned every actuator off (trips since its power-up)


@dataclass(frozen=True)
class Pong:
    rtt_s: float  # PING write → PONG receipt


class DeviceSession:
    def __init__(self, *, share: float = 0.5, byte_time_s: float = BYTE_TIME_S, hello_interval_s: float = 0.25,
                 ping_interval_s: float = 0.5, silence_timeout_s: float = 1.5, ack_timeout_s: float = 0.5,
                 watchdog_ms: int = 0, keepalive_interval_s: float = KEEPALIVE_INTERVAL_S):
        if watchdog_ms:
            m.SetWatchdog(watchdog_ms)  # a range check, with the message's own error
            if not 0 < keepalive_interval_s * 1000 < watchdog_ms:
                raise ValueError(f"keepalive_interval_s ({keepalive_interval_s}) must be shorter than the watchdog "
                                 f"({watchdog_ms} ms)")
        self.watchdog_ms = watchdog_ms
        self.keepalive_interval_s = keepalive_interval_s
        self.watchdog = "off"  # off | pending | on | unsupported
        self.hello_interval_s = hello_interval_s
        self.ping_interval_s = ping_interval_s
        self.silence_timeout_s = silence_timeout_s
        self.ack_timeout_s = ack_timeout_s
        self.status = DISCONNECTED
        self.identity: m.Identify | None = None  # the last version-1 IDENTIFY
        self.rtt_s: float | None = None
        self.counters: dict[str, int] = dict.fromkeys(
            ("frames_in", "frames_out", "bytes_out", "acks", "device_errors", "resent", "watchdog_trips", *REJECT_KINDS),
            0)
        self.budget = LinkBudget(share, byte_time_s)
        self.book = CommandBook()
        self._decoder = FrameDecoder()
        self._unpacked: dict[tuple[int, bytes], object] = {}  # see _unpack
        self._events: list = []
        self._seq = 0
        self._frames: dict[int, tuple[object, float]] = {}  # seq -> (message, written at): the last 256
        self._flush = False
        self._hello_due: float | None = None
        self._ping_due: float | None = None
        self._ping_tokens: dict[int, float] = {}  # token -> written at
        self._next_token = 1
        self._last_rx = 0.0
        self._last_tx = 0.0
        self._watchdog_due: float | None = None
        self._watchdog_sent: tuple[int, float] | None = None  # (seq, written at) of the last SET_WATCHDOG

    # ---- connection ------------------------------------------------------------------------

    def connection_made(self, now_s: float) -> None:
        self._decoder.reset()
        self._frames.clear()
        self._ping_tokens.clear()
        self._flush = True  # §4.1: one 0x00 flushes the device's partial frame, then HELLO
        self._hello_due = self._ping_due = None
        self._last_rx = now_s
        self._watchdog_due = self._watchdog_sent = None
        self.watchdog = "off"
        self.book.requeue_all()  # §4.4: after a (re)connect every layer is sent again
        self._set_status(HANDSHAKING, "port opened")

    def connection_lost(self, now_s: float, reason: str) -> None:
        self._decoder.reset()
        self._flush = False
        self._hello_due = self._ping_due = None
        self._set_status(DISCONNECTED, reason)

    # ---- input -----------------------------------------------------------------------------

    def receive_data(self, data: bytes, now_s: float) -> None:
        if self.status == DISCONNECTED:
            return  # bytes of a port already given up
        for item in self._decoder.feed(data):
            if isinstance(item, FrameError):
                self._reject(item)
            else:
                self._receive_frame(item, now_s)

    def _receive_frame(self, frame: Frame, now_s: float) -> None:
        self._last_rx = now_s  # §4.3: any good frame shows the device is alive
        if self.status == UNRESPONSIVE:
            # it may have been power-cycled behind an open port: resend every layer (§4.4)
            self.counters["resent"] += self.book.requeue_all()
            self._arm_watchdog(now_s)
            self._set_status(CONNECTED, "device answers again")
        if frame.type == m.Identify.TYPE and frame.payload and frame.payload[0] != m.PROTOCOL_VERSION:
            # checked before parsing: another version's IDENTIFY may have another layout (§6)
            self._hello_due = None
            self._set_status(BAD_VERSION, f"device speaks protocol version {frame.payload[0]}")
            return
        try:
            message = self._unpack(frame)
        except m.MessageError as exc:
            self._reject(FrameError(exc.kind, frame.payload, f"type {frame.type:#04x} seq {frame.seq}: {exc}"))
            return
        if message.FROM_HOST:
            self._reject(FrameError("unknown_type", frame.payload, f"{type(message).__name__} is not a device message"))
            return
        self.counters["frames_in"] += 1
        if isinstance(message, m.Identify):
            self._hello_due = None
            if message != self.identity:
                self.identity = message
                self._events.append(Identified(message))
            if self.status in (HANDSHAKING, BAD_VERSION):
                self._ping_due = now_s  # first PING at once: an RTT right away
                self._arm_watchdog(now_s)
                self._set_status(CONNECTED, f"{message.model} firmware {message.firmware}")
        elif isinstance(message, m.Pong):
            sent_at = self._ping_tokens.pop(message.token, None)
            if sent_at is not None:
                self.rtt_s = now_s - sent_at
                self._events.append(Pong(self.rtt_s))
        elif isinstance(message, m.WatchdogTripped):
            # every layer went off behind our back (we were silent too long): show them again
            self.counters["watchdog_trips"] += 1
            self.counters["resent"] += self.book.requeue_all()
            self._events.append(WatchdogReported(message.trips))
        elif isinstance(message, m.Ack):
            if self._watchdog_sent is not None and message.ref_seq == self._watchdog_sent[0]:
                self._watchdog_sent = None
                self.watchdog = "on"
            self.counters["acks"] += 1
            self.book.mark_acked(message.ref_seq)
            sent = self._frames.get(message.ref_seq)
            self._events.append(Acked(message.ref_seq, None if sent is None else now_s - sent[1],
                                      None if sent is None else sent[0]))
        elif isinstance(message, m.Error):
            self._device_error(message)

    def _device_error(self, error: m.Error) -> None:
        if self._watchdog_sent is not None and error.ref_seq == self._watchdog_sent[0]:
            # a firmware older than SET_WATCHDOG (§6): it works as before, without keepalives
            self._watchdog_sent = None
            self.watchdog = "unsupported" if error.code == m.ErrorCode.UNKNOWN_TYPE else "off"
            self._events.append(DeviceErrorReported(error.ref_seq, error.code, repr(m.SetWatchdog(self.watchdog_ms))))
            return
        self.counters["device_errors"] += 1
        if error.code in m.UNTRUSTED_SEQ_CODES:
            # the device could not read a frame, so some command may be lost: resend what is
            # not acknowledged yet (§3: ref_seq is 0xFF and names nothing)
            self.counters["resent"] += self.book.requeue_unacked()
            self._events.append(DeviceErrorReported(error.ref_seq, error.code, None))
            return
        self.book.mark_acked(error.ref_seq)  # answered: not lost, and resending would fail again
        sent = self._frames.get(error.ref_seq)
        self._events.append(DeviceErrorReported(error.ref_seq, error.code, None if sent is None else repr(sent[0])))
        if error.code == m.ErrorCode.BAD_VERSION:
            self._hello_due = None
            self._set_status(BAD_VERSION, "device refused HELLO version 1")

    def _unpack(self, frame: Frame):
        """m.unpack, once per distinct payload: it is pure and messages are immutable, and a
        device's replies repeat (an ACK per seq). A payload it refuses is not kept."""
        key = (frame.type, frame.payload)
        message = self._unpacked.get(key)
        if message is None:
            message = m.unpack(frame.type, frame.payload)
            if len(self._unpacked) >= _UNPACKED_KEPT:
                self._unpacked.clear()
            self._unpacked[key] = message
        return message

    def _reject(self, error: FrameError) -> None:
        self.counters[error.kind] = self.counters.get(error.kind, 0) + 1
        self._events.append(FrameRejected(error))

    # ---- commands and output ---------------------------------------------------------------

    def set(self, message, now_s: float) -> bool:
        """The newest value of one layer (a SET_* or STOP message); latest wins per layer_key.

        Returns whether a poll may now do something new. False: commands waited before and still
        do (or neither), which is all a poll asks of them until it writes, and no timer is due at
        now_s. So for a driver whose last poll returned a wake_at later than now_s and that has
        received nothing since, a poll now would change nothing and return that same wake_at
        (every send it could make is due at or after wake_at): it may skip it. A simulated
        link does, on most ticks; a driver that always polls loses nothing."""
        return self.book.set(message, now_s) or self._timers_due(now_s)

    def poll(self, now_s: float) -> tuple[bytes, float | None]:
        if self.status == DISCONNECTED:
            return b"", None
        self._check_timers(now_s)
        budget = self.budget
        if not now_s >= budget.ready_at:  # not budget.ready(now_s): it would refuse any write (most polls)
            return b"", self._wake_at(now_s)
        data = self._next_write(now_s)  # budget.write(now_s, produce), without a closure per poll
        if data:
            budget.spend(len(data), now_s)
            self.counters["bytes_out"] += len(data)
        return data, self._wake_at(now_s)

    def events_received(self) -> list:
        events, self._events = self._events, []
        return events

    def _arm_watchdog(self, now_s: float) -> None:
        if self.watchdog_ms and self.watchdog != "unsupported":
            self._watchdog_due = now_s
            self.watchdog = "pending"

    def _keepalive_due(self) -> float | None:
        """When the next frame must leave so the device's watchdog stays fed; None if it need not."""
        if self.watchdog in ("pending", "on") and self.status in (CONNECTED, UNRESPONSIVE):
            return self._last_tx + self.keepalive_interval_s
        return None

    def _check_timers(self, now_s: float) -> None:
        # _timers_due asks the same three questions: keep them in step
        if self._watchdog_sent is not None and now_s - self._watchdog_sent[1] >= self.ack_timeout_s:
            self._watchdog_sent, self._watchdog_due = None, now_s  # no answer: send it again
        if self.status == CONNECTED and now_s - self._last_rx >= self.silence_timeout_s:
            self._set_status(UNRESPONSIVE, f"no frame from the device for {self.silence_timeout_s:g} s")
        if self.status == CONNECTED:
            oldest = self.book.oldest_unacked_at()
            if oldest is not None and now_s - oldest >= self.ack_timeout_s:
                self.counters["resent"] += self.book.requeue_unacked()

    def _timers_due(self, now_s: float) -> bool:
        """Whether _check_timers(now_s) would act: its tests, without acting."""
        if self._watchdog_sent is not None and now_s - self._watchdog_sent[1] >= self.ack_timeout_s:
            return True
        if self.status != CONNECTED:
            return False
        if now_s - self._last_rx >= self.silence_timeout_s:
            return True
        oldest = self.book.oldest_unacked_at()
        return oldest is not None and now_s - oldest >= self.ack_timeout_s

    def _next_write(self, now_s: float) -> bytes:
        if self._flush:
            self._flush = False
            self._hello_due = now_s + self.hello_interval_s
            return b"\x00" + self._frame(m.Hello(), now_s)
        if self._hello_due is not None and self._hello_due <= now_s:
            self._hello_due = now_s + self.hello_interval_s  # §4.2: again, for ever, ≤ 4/s
            return self._frame(m.Hello(), now_s)
        if self._watchdog_due is not None and self._watchdog_due <= now_s:
            self._watchdog_due = None
            self._watchdog_sent = (self._seq, now_s)
            return self._frame(m.SetWatchdog(self.watchdog_ms), now_s)
        keepalive = self._keepalive_due()
        if (self._ping_due is not None and self._ping_due <= now_s) or (
                keepalive is not None and keepalive <= now_s and not self.book.pending):
            if self._ping_due is not None and self._ping_due <= now_s:
                self._ping_due = now_s + self.ping_interval_s
            token, self._next_token = self._next_token, (self._next_token + 1) & 0xFFFF_FFFF
            self._ping_tokens[token] = now_s
            while len(self._ping_tokens) > _PING_TOKENS_KEPT:
                del self._ping_tokens[next(iter(self._ping_tokens))]
            return self._frame(m.Ping(token), now_s)
        nxt = self.book.pop_next()
        if nxt is None:
            return b""
        key, message, since = nxt
        seq = self._seq
        data = self._frame(message, now_s)
        self.book.mark_written(key, message, since, now_s, seq)
        return data

    def _frame(self, message, now_s: float) -> bytes:
        seq, self._seq = self._seq, (self._seq + 1) & 0xFF
        self._frames[seq] = (message, now_s)  # seq wraps at 256, so this keeps the last 256
        self.counters["frames_out"] += 1
        self._last_tx = now_s
        return encode_frame(message.TYPE, seq, message.pack())

    def _wake_at(self, now_s: float) -> float | None:
        """The earliest time a poll has something to do: when each kind of frame wants to go out,
        but not before the budget allows, and the timers of _check_timers; never before now_s."""
        # min/max written out (ties keep the first, as min() and max() do): no lists on every poll
        ready = self.budget.ready_at
        best = ready if self._flush else None           # a flush is due at once (-inf): the budget decides
        keepalive = None if self.watchdog == "off" else self._keepalive_due()  # none while off
        for t in (self._hello_due, self._ping_due, self._watchdog_due, keepalive):
            if t is not None:
                t = ready if ready > t else t
                if best is None or t < best:
                    best = t
        if self.book.pending and (best is None or ready < best):  # a command is due at once, too
            best = ready
        if self.status == CONNECTED:
            t = self._last_rx + self.silence_timeout_s
            if best is None or t < best:
                best = t
            oldest = self.book.oldest_unacked_at()
            if oldest is not None:
                t = oldest + self.ack_timeout_s
                if best is None or t < best:
                    best = t
        if self._watchdog_sent is not None:
            t = self._watchdog_sent[1] + self.ack_timeout_s
            if best is None or t < best:
                best = t
        if best is None:
            return None
        return now_s if now_s > best else best

    def _set_status(self, new: str, reason: str) -> None:
        if new != self.status:
            old, self.status = self.status, new
            self._events.append(StatusChanged(old, new, reason))
