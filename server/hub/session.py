"""One /ws client's protocol session, I/O-free (the shape of websockets' sans-I/O protocol core).

The hub's shell (server/hub/fanout.py) owns the socket and the clock; this object owns every
protocol decision about one client:
- the hello grace period (HELLO_TIMEOUT_NS): the first frame must be a `hello` with a valid token, by the deadline
  (`hello_deadline_passed`); without one the client gets `unauthorized` and the connection closes
  (1008) (docs/protocol.md "Authentication and roles");
- the version check (`unsupported_version`, then close 1002);
- who the client is and what it may do: the token's identity (server/auth), the role granted
  for the one asked, and every message checked against the declared policy
  (`server.auth.policy.POLICY`, `decide`) and the control lease, through `Gate`, what the
  session asks of access control (injected: the session itself does no I/O);
- decoding and validation (server/wire), with exactly one `error` per bad frame;
- what the client is sent and when: its `outbox` (server/hub/outbox.py: an ordered control queue
  and a latest-wins slot for state frames, taken by the shell's sender with `next_frame()`);
- the ordering rule: every state after `scene` H names H until the next `scene` (the outbox
  drops a state frame of a scene the client was not sent);
- the input budget (server/hub/input_budget.py): `input` and `answer` messages spend its tokens;
  one over budget is dropped with `rate_limited`, at most one such error a second (the rest are
  counted); refusals of tracker samples (a client that may not drive) are answered at the same
  pace;
- a participant's study answers (v1.5 `answer`): they come out as `ParticipantAnswer` for the
  experiment engine, always for the token's own session; a participant connection of a session
  is sent that session's latest `ask` (`set_ask`);
- per-client counters.

What a client asks of the loop comes out of `receive` as events (`ToLoop`, `Command`); the hub
forwards them and reports a refusal back with `reply_error`. When the lease changes
(`set_lease`), a client that drove the HIP and may no longer gets a `tracker_gone` for the loop,
and a participant whose session closes is told so (`session_closed`). A token revoked or expired
while connected ends the connection (`withdraw`: `unauthorized`, close 1008 with reason "revoked"
or "expired"); a participant connection of a session opened again elsewhere (another tab) only
watches from then on (`withdraw("taken")`: `session_taken`). Activity that reaches the rig renews the
lease holder's lease (`Gate.keepalive`, at most once a second per connection).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Mapping

from server.auth import Unauthorized
from server.auth.identity import Identity
from server.auth.policy import POLICY, RunningTrial, decide
from server.hub.event_log import EventLog
from server.hub.input_budget import (FORBIDDEN_TRACKER_ERROR_EVERY_NS, INPUT_BURST, INPUT_RATE_PER_S,
                                     RATE_LIMITED_ERROR_EVERY_NS, InputBudget)
from server.hub.outbox import Outbox
from server.ipc.records import Record, TrackerGone
from server.wire import codec, messages
from server.wire.codec import WireError

# The hello grace period. Measured from the accept to the hello of real pages (the console, its
# participant view and a participant page, headless Chromium) on a 2-core machine already loaded by
# other work plus two CPU hogs: median 0.45 s, p90 1.5 s, max 6.0 s (docs/protocol.md). 10 s admits
# every one of them; the pages also retry a late hello (clients/web/src/connection.js).
HELLO_TIMEOUT_NS = 10_000_000_000
KEEPALIVE_EVERY_NS = 1_000_000_000  # a streaming client renews the lease at most this often
POLICY_CLOSE = 1008  # RFC 6455 "policy violation": no valid token, or too many connections of one token
# Why a welcomed connection's token stopped counting: the close frame's reason (a page shows it and does
# not reconnect with that token) and the `unauthorized` error's text (docs/security.md).
LAPSES = {"revoked": "your access was revoked", "expired": "your access expired: ask for a new link"}
# The wire role a token may ask for, highest first: observer < participant < operator.
_RANK = {"observer": 0, "participant": 1, "operator": 2}
MAX_WIRE_ROLE = {"admin": "operator", "experimenter": "operator", "participant": "participant",
                 "observer": "observer"}


@dataclass(frozen=True)
class Gate:
    """What a session asks of access control (server/auth, through the hub): injected, so the
    session makes every decision without doing I/O itself.

    authenticate(secret) -> Identity, or raises server.auth.Unauthorized (unknown, expired, revoked
    or missing token; a token or code throttled after failed attempts with its prefix);
    lease() -> the current control lease (server.auth.lease.Lease);
    admit(identity) -> None, or why this token may not open another connection;
    running() -> the trial being recorded (server.auth.policy.RunningTrial) or None;
    keepalive(identity) -> None: activity of `identity` reached the rig (renews the lease holder)."""
    authenticate: Callable[[str | None], Identity]
    lease: Callable[[], Any]
    admit: Callable[[Identity], str | None] = lambda who: None
    running: Callable[[], RunningTrial | None] = lambda: None
    keepalive: Callable[[Identity], None] = lambda who: None


def gate_of(access, peer: str, admit: Callable[[Identity], str | None]) -> Gate:
    """The Gate of a connection from `peer` to the server's AccessControl (server/auth); a stand-in
    without `running` or `keepalive` (a test's) has no running trial and renews nothing."""
    return Gate(lambda secret: access.authenticate(secret, peer), lambda: access.lease, admit,
                getattr(access, "running", lambda: None), getattr(access, "keepalive", lambda who: None))


def _refuse_everyone(secret: str | None) -> Identity:
    raise Unauthorized("this server has no access control configured; it accepts no client")


CLOSED = Gate(_refuse_everyone, lambda: None)  # fail closed: a hub without access control admits nobody


def granted_role(identity: Identity, asked: str) -> str:
    """The wire role for a token that asked for `asked`: as asked up to what its role allows."""
    top = MAX_WIRE_ROLE.get(identity.role, "observer")
    return asked if _RANK[asked] <= _RANK[top] else top


TAKEN = ("this session was opened in another tab or on another device: that one drives now and this one only "
         "watches (reload this page to drive here again)")
SESSION_CLOSED = ("your session was closed: the experimenter no longer has it open on the rig (the rig was "
                  "released or given to someone else); wait until they open it again")


@dataclass(frozen=True)
class ServerInfo:
    """What a welcome says about the server."""
    name: str
    tick_hz: int
    state_hz: float


@dataclass(frozen=True)
class ToLoop:
    """A record for the loop's mailbox. `busy`: the error text for the client if the record
    cannot go (full mailbox); None when there is nobody to tell."""
    record: Record
    busy: str | None = None


@dataclass(frozen=True)
class Command:
    """A key or command for the running scenario, checked by the hub against its CONTROLS."""
    key: str
    action: str
    value: Any
    role: str
    client_id: int


@dataclass(frozen=True)
class ParticipantAnswer:
    """A participant's answer (protocol v1.5 `answer`) for the experiment engine: the session is
    the token's own, never one the client names."""
    session_id: str
    seq: int
    question: str
    value: Any
    identity: Identity
    client_id: int


@dataclass(frozen=True)
class ActuatorsOffered:
    """The actuators a participant page offers (protocol v1.6 `actuators`; `()` when it leaves):
    the hub's browser device (server/hub/browser_actuators.py)."""
    client_id: int
    actuators: tuple[tuple[str, str], ...]
    note: str
    left: bool = False  # the connection closed: its offer goes


class Session:
    def __init__(self, client_id: int, fmt: str, server: ServerInfo, opened_ns: int, *, gate: Gate = CLOSED,
                 hello_timeout_ns: int = HELLO_TIMEOUT_NS, events: EventLog | None = None):
        self.id = client_id
        self.fmt = fmt
        self.server = server
        self.gate = gate
        self.identity: Identity | None = None  # the token's, once the hello was accepted
        self.role = "observer"
        self.client_name = ""
        self.welcomed = False
        self.close_code: int | None = None
        self.hello_deadline_ns = opened_ns + hello_timeout_ns
        self.outbox = Outbox(fmt, events)  # what the client is sent, in order
        self._scene: tuple[str, bytes | str] | None = None  # the current scene in this client's format
        self._health: bytes | str | None = None  # the current `health` message in this client's format
        self._lease: bytes | str | None = None  # the current `lease` message in this client's format
        self._ask: bytes | str | None = None  # the current `ask` message (participants of a session)
        self._driving = False  # tracker samples of this client went to the loop since it last lost the right
        self._offered = False  # its last `actuators` message offered some (the hub's browser device)
        self._keepalive_due_ns = 0  # when this client's activity next renews the lease
        self._session_open = False  # a participant connection's: it might drive at the last lease change
        self.replaced_by: int | None = None  # a participant connection whose session another connection took
        self.lapsed: str | None = None  # "revoked" | "expired": the token stopped counting while connected
        # counters (GET /api/clients; the outbox counts the frames)
        self.tracker_count = 0
        self.last_tracker: dict | None = None
        self.errors = 0
        self.rate_limited = 0  # inputs dropped over the budget
        self.budget = InputBudget(opened_ns)

    @property
    def closing(self) -> bool:
        return self.close_code is not None

    @property
    def asks_for(self) -> str | None:
        """The session whose `ask` messages this client gets: a welcomed participant connection of a
        participant token that names a session; else None."""
        who = self.identity
        if not self.welcomed or self.role != "participant" or who is None or who.role != "participant":
            return None
        return who.session

    def info(self) -> dict:
        who = self.identity
        return {"client_id": self.id, "role": self.role, "client": self.client_name, "format": self.fmt,
                "token_id": who.token_id if who else None, "site": who.site if who else None,
                "session": self.asks_for, "replaced_by": self.replaced_by,
                "frames_sent": self.outbox.frames_sent, "frames_dropped": self.outbox.frames_dropped,
                "tracker_count": self.tracker_count, "last_tracker": self.last_tracker, "errors": self.errors,
                "rate_limited": self.rate_limited}

    # ---- time --------------------------------------------------------------------------------
    def hello_wait_s(self, now_ns: int) -> float | None:
        """Seconds the shell may wait for the first frame before calling `hello_deadline_passed`;
        None once the grace period is over."""
        if self.welcomed or self.closing:
            return None
        return max(0.0, (self.hello_deadline_ns - now_ns) / 1e9)

    def hello_deadline_passed(self, now_ns: int) -> None:
        """No hello in time: without a token the client is refused (unauthorized, close 1008)."""
        if not self.welcomed and not self.closing and now_ns >= self.hello_deadline_ns:
            self._refuse("unauthorized", f"no hello with a token within {HELLO_TIMEOUT_NS / 1e9:g} s of connecting")

    # ---- frames from the client --------------------------------------------------------------
    def receive(self, data: bytes | str | None, now_ns: int) -> list[ToLoop | Command | ParticipantAnswer]:
        """One frame from the client (None: a frame with no payload). Returns what the hub is to
        forward; replies (welcome, errors, close) are queued for the sender."""
        if self.closing:
            return []
        self.hello_deadline_passed(now_ns)  # a frame after the deadline comes after the welcome
        events: list[ToLoop | Command] = []
        try:
            if data is None:
                raise WireError("bad_encoding", "empty frame")
            body = codec.decode(data, self.fmt)
            message = messages.parse_client_message(body)
        except WireError as exc:
            if not self.welcomed:  # one error per frame: this one, then the connection closes
                self._refuse("unauthorized", f"the first message must be a hello with a token ({exc.code}: {exc.message})")
                return []
            self.reply_error(exc.code, exc.message)
        else:
            if not self.welcomed and not isinstance(message, messages.Hello):
                self._refuse("unauthorized", f"the first message must be a hello with a token, not {body['type']!r}")
                return []
            events = self._handle(body["type"], message, now_ns)
        if not self.welcomed and not self.closing:  # the first frame ends the grace period, hello or not
            self._refuse("unauthorized", "the first message must be a hello with a token")
        return events

    def refusal(self, kind: str) -> str | None:
        """None when this client may send messages of `kind` now ("tracker", "input", "answer", or
        "input:operator", an experimenter command), else the reason: the role it was welcomed
        with, then the declared policy (server.auth.policy) against its identity and the lease."""
        base = kind.split(":")[0]
        if self.role == "observer":
            return f"an observer may not send '{base}' messages"
        if self.replaced_by is not None:
            return TAKEN
        rule = POLICY[f"ws:{kind}"]
        verdict = decide(rule, self.identity, self.gate.lease(), self.gate.running() if rule.recorded else None)
        if verdict is None and kind == "answer" and self.asks_for is None:
            return "this participant token names no session: there is nothing to answer"
        return None if verdict is None else verdict[1]

    def _handle(self, kind: str, message, now_ns: int) -> list[ToLoop | Command | ParticipantAnswer]:
        if isinstance(message, messages.Hello):
            self._hello(message)
            return []
        refusal = self.refusal(kind)
        if refusal is not None:
            # a tracker stream comes at up to 1 kHz: one `forbidden` a second, the rest counted
            if kind != "tracker" or self.budget.reply_due("tracker", FORBIDDEN_TRACKER_ERROR_EVERY_NS, now_ns):
                self.reply_error("forbidden", refusal)
            else:
                self.errors += 1
            return []
        # answers share the input budget: each one is a disk write (and an actuators offer a device change)
        if isinstance(message, (messages.Input, messages.Answer, messages.Actuators)) and not self.budget.spend(now_ns):
            self.rate_limited += 1
            if self.budget.reply_due("input", RATE_LIMITED_ERROR_EVERY_NS, now_ns):
                self.reply_error("rate_limited", f"more than {INPUT_RATE_PER_S:g} inputs a second (bursts of "
                                                 f"{INPUT_BURST}): input dropped ({self.rate_limited} so far)")
            else:
                self.errors += 1  # refused without a reply: counted, not queued
            return []
        if now_ns >= self._keepalive_due_ns:  # it reaches the rig: the lease holder's lease stays alive
            self._keepalive_due_ns = now_ns + KEEPALIVE_EVERY_NS
            self.gate.keepalive(self.identity)
        if isinstance(message, messages.Tracker):
            self._driving = True
            self.tracker_count += 1
            self.last_tracker = {"seq": message.seq, "t": message.t_ms, "pos": list(message.pos)}
            record = message.loop_record(self.id, now_ns)
            return [ToLoop(record, busy="the loop's input mailbox is full; tracker sample dropped")]
        if isinstance(message, messages.Input):
            return [Command(message.key, message.action, message.value, self.role, self.id)]
        if isinstance(message, messages.Answer):
            return [ParticipantAnswer(self.asks_for, message.seq, message.question, message.value, self.identity,
                                      self.id)]
        if isinstance(message, messages.Actuators):
            self._offered = True
            return [ActuatorsOffered(self.id, message.actuators, message.note)]
        return []

    def _hello(self, hello: messages.Hello) -> None:
        if hello.version != messages.PROTOCOL_VERSION:
            self.reply_error("unsupported_version", f"protocol version {hello.version} is not supported; "
                                                    f"this server speaks v{messages.PROTOCOL_VERSION}")
            self.close_code = 1002
            self.outbox.close(1002)
            return
        if self.welcomed:
            self.reply_error("bad_message", "hello must be the first message of a connection")
            return
        try:
            who = self.gate.authenticate(hello.token or None)
        except Unauthorized as exc:
            self._refuse("unauthorized", exc.message)
            return
        verdict = decide(POLICY["ws:hello"], who, self.gate.lease())
        if verdict is not None:
            self._refuse("unauthorized" if verdict[0] == 401 else "forbidden", verdict[1])
            return
        crowded = self.gate.admit(who)
        if crowded is not None:
            self._refuse("rate_limited", crowded)
            return
        self.identity, self.client_name = who, hello.client
        self.role = granted_role(who, hello.role)
        self._welcome()
        if self.role != hello.role:
            self.reply_error("forbidden", f"a {who.role} token may not connect as {hello.role}; "
                                          f"connected as {self.role}")

    def _refuse(self, code: str, text: str, reason: str = "") -> None:
        """One error, then close 1008 (with `reason`); nothing else is sent (no welcome, no scene, no state)."""
        self.reply_error(code, text)
        self.close_code = POLICY_CLOSE
        self.outbox.close(POLICY_CLOSE, reason)

    def withdraw(self, why: str, by_client_id: int | None = None) -> list[ToLoop]:
        """This connection's right to act ends; a client that drove the HIP leaves it at once.
        "revoked" | "expired" (LAPSES): the token stopped counting while connected; the client is
        told why and the connection closes (1008, reason `why`), nothing it sends is applied any more.
        "taken": another connection of this participant's session was welcomed (a second tab or
        device, `by_client_id`); the newer one drives and answers, this one is told and only watches."""
        if self.closing or self.identity is None or self.replaced_by is not None:
            return []
        if why == "taken":
            self.replaced_by = by_client_id
            self.reply_error("session_taken", TAKEN)
        else:
            self.lapsed = why
            self._refuse("unauthorized", LAPSES[why], why)
        if not self._driving:
            return []
        self._driving = False
        return [ToLoop(TrackerGone(self.id))]

    def disconnected(self) -> list[ToLoop | ActuatorsOffered]:
        """The connection is gone: a client whose tracker samples reached the loop leaves the HIP
        (the loop sends it home and clears its driver); a page that offered actuators takes them away."""
        return ([ToLoop(TrackerGone(self.id))] if self.tracker_count else []) + \
            ([ActuatorsOffered(self.id, (), "", left=True)] if self._offered else [])

    def set_lease(self, frames: Mapping[str, bytes | str]) -> list[ToLoop]:
        """The control lease changed (`frames`: the `lease` message encoded per format). A welcomed
        client is sent it (one still queued is superseded); a client that drove the HIP and may
        no longer leaves it: the returned `tracker_gone` sends the HIP home."""
        self._lease = frames[self.fmt]
        if self.welcomed and not self.closing:
            self.outbox.latest("lease", self._lease)
            # a participant whose session closes while it is connected is told so in words, once per
            # closing; it is open again when `lease.session` names it (docs/security.md)
            was_open, self._session_open = self._session_open, self.asks_for is not None and self.refusal("tracker") is None
            if was_open and not self._session_open and self.replaced_by is None:
                self.reply_error("session_closed", SESSION_CLOSED)
        if self._driving and self.refusal("tracker") is not None:
            self._driving = False
            return [ToLoop(TrackerGone(self.id))]
        return []

    # ---- what the client is sent -------------------------------------------------------------
    def reply_error(self, code: str, text: str) -> None:
        """One `error` frame for the client (also for refusals the hub learns: busy, command rules)."""
        self.errors += 1
        if not self.closing:
            self.outbox.error(code, text)

    def _welcome(self) -> None:
        self.welcomed = True
        s = self.server
        identity = self.identity.to_dict() if self.identity is not None else None
        welcome = messages.welcome(self.id, self.role, s.name, s.tick_hz, s.state_hz, self.fmt, identity)
        out = self.outbox
        out.put("welcome", codec.encode(welcome, self.fmt))
        if self._scene is not None:
            out.put("scene", self._scene[1], self._scene[0])
        if self._health is not None:  # after the scene: a v1.0 client reads welcome, then scene
            out.put("health", self._health)
        if self._lease is not None:
            out.put("lease", self._lease)
        if self._ask is not None and self.asks_for is not None:
            out.put("ask", self._ask)
        self._session_open = self.asks_for is not None and self.refusal("tracker") is None

    def set_ask(self, frames: Mapping[str, bytes | str]) -> None:
        """What the study asks of this participant now (`frames`: the `ask` message per format; the
        hub offers it only to clients whose `asks_for` is its session). One still queued is
        superseded: only the latest is true."""
        self._ask = frames[self.fmt]
        if self.asks_for is None or self.closing:
            return
        self.outbox.latest("ask", self._ask)

    def set_scene(self, scene_hash: str, frames: Mapping[str, bytes | str]) -> None:
        """The current scene (`frames`: its scene message encoded per format). A welcomed client
        is sent it; a scene still waiting in the queue is superseded (the client needs the latest)."""
        self._scene = (scene_hash, frames[self.fmt])
        if not self.welcomed or self.closing:
            return
        self.outbox.latest("scene", self._scene[1], scene_hash)

    def set_health(self, frames: Mapping[str, bytes | str]) -> None:
        """The server's current `health` message (`frames`: encoded per format). A welcomed client
        is sent it; one still waiting in the queue is superseded (the latest is what is true)."""
        self._health = frames[self.fmt]
        if not self.welcomed or self.closing:
            return
        self.outbox.latest("health", self._health)

    def offer_state(self, frame: bytes | str, scene_hash: str, message: Mapping[str, Any] | None = None,
                    events_upto: int | None = None) -> None:
        """The latest state frame (in this client's format) and the scene it names; it replaces a
        frame not yet sent (counted as dropped). Clients not yet welcomed get none. With the
        frame's `message` and the number its events end at in the hub's EventLog, a frame sent
        after missed ones is encoded again with their events first (Outbox.next_frame)."""
        if not self.welcomed or self.closing:
            return
        self.outbox.offer_state(frame, scene_hash, message, events_upto)
