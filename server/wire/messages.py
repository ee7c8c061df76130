"""Protocol v1.6 messages (docs/protocol.md): validated client messages, server message builders.

Every message is declared once in schema.py. Client messages are frozen dataclasses parsed from
a decoded map by the declaration's checker (check.py): a wrong field is
`WireError("bad_message", ...)` naming the field. Server messages are built as maps in the
declared field order, because the msgpack test vectors are byte-exact.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

from server.ipc.records import TrackerSample
from server.wire.check import check_message
from server.wire.codec import WireError, echo
from server.wire.schema import (ACTUATORS, ANSWER, CLIENT_MESSAGE_NAMES, HELLO, INPUT, INPUT_ACTIONS, MAX_ERROR_MESSAGE_CHARS,
                                PROTOCOL_MINOR,
                                PROTOCOL_VERSION, ROLES, SCENE_FORMAT_VERSION, STATE, TRACKER)

__all__ = ["PROTOCOL_VERSION", "PROTOCOL_MINOR", "ROLES", "INPUT_ACTIONS", "Hello", "Tracker", "Input", "Answer", "Actuators",
           "CLIENT_MESSAGES", "parse_client_message", "welcome", "scene_message", "state_message", "error", "health",
           "lease", "ask"]


@dataclass(frozen=True)
class Hello:
    version: int
    role: str
    client: str
    token: str | None = field(default=None, repr=False)  # a secret: never in a repr, a log line or an error

    @classmethod
    def parse(cls, body: dict) -> Hello:
        f = check_message(body, HELLO)
        return cls(f["v"], f["role"], f["client"], f["token"])

    def to_wire(self) -> dict:
        msg = {"type": "hello", "v": self.version, "role": self.role, "client": self.client}
        if self.token:
            msg["token"] = self.token
        return msg


@dataclass(frozen=True)
class Tracker:
    seq: int
    t_ms: float
    pos: tuple[float, float, float]
    quat: tuple[float, float, float, float] | None = None  # unit: the parser divides by the norm
    point: str | None = None     # v1.4: the point `pos` is (None: the primary tool's)
    points: dict[str, tuple[float, float, float]] | None = None  # v1.4: more points of the sample
    ttl_ms: float | None = None  # v1.4: the sample is good for this long (None: held)

    @classmethod
    def parse(cls, body: dict) -> Tracker:
        f = check_message(body, TRACKER)
        return cls(f["seq"], f["t"], f["pos"], f["quat"], f["point"], f["points"], f["ttl"])

    def to_wire(self) -> dict:
        msg: dict[str, Any] = {"type": "tracker", "seq": self.seq, "t": self.t_ms, "pos": list(self.pos)}
        if self.quat is not None:
            msg["quat"] = list(self.quat)
        if self.point is not None:
            msg["point"] = self.point
        if self.points is not None:
            msg["points"] = {name: list(p) for name, p in self.points.items()}
        if self.ttl_ms is not None:
            msg["ttl"] = self.ttl_ms
        return msg

    def loop_record(self, source: int | str, recv_ns: int) -> TrackerSample:
        """The loop's tracker record (server/ipc/records.py)."""
        return TrackerSample(source, self.seq, self.t_ms, list(self.pos), list(self.quat) if self.quat else None,
                             recv_ns, self.point,
                             {name: list(p) for name, p in self.points.items()} if self.points else None, self.ttl_ms)


@dataclass(frozen=True)
class Input:
    key: str
    action: str
    value: bool | float | str | None = None  # a command's argument, e.g. tap_angle 30

    @classmethod
    def parse(cls, body: dict) -> Input:
        f = check_message(body, INPUT)
        return cls(f["key"], f["action"], f["value"])

    def to_wire(self) -> dict:
        msg: dict[str, Any] = {"type": "input", "key": self.key, "action": self.action}
        if self.value is not None:
            msg["value"] = self.value
        return msg


@dataclass(frozen=True)
class Answer:
    """v1.5: a participant's answer to a question of its session's running trial."""
    seq: int
    question: str
    value: float | str

    @classmethod
    def parse(cls, body: dict) -> Answer:
        f = check_message(body, ANSWER)
        return cls(f["seq"], f["question"], f["value"])

    def to_wire(self) -> dict:
        return {"type": "answer", "seq": self.seq, "question": self.question, "value": self.value}


@dataclass(frozen=True)
class Actuators:
    """v1.6: the actuators a participant page can drive, `(kind, hand)` each; () with a `note`: none."""
    actuators: tuple[tuple[str, str], ...]
    note: str = ""

    @classmethod
    def parse(cls, body: dict) -> Actuators:
        f = check_message(body, ACTUATORS)
        return cls(tuple(tuple(a) for a in f["actuators"]), f["note"])

    def to_wire(self) -> dict:
        msg: dict[str, Any] = {"type": "actuators", "actuators": [list(a) for a in self.actuators]}
        if self.note:
            msg["note"] = self.note
        return msg


CLIENT_MESSAGES = {"hello": Hello, "tracker": Tracker, "input": Input, "answer": Answer, "actuators": Actuators}
assert tuple(CLIENT_MESSAGES) == CLIENT_MESSAGE_NAMES


def parse_client_message(body: dict) -> Hello | Tracker | Input | Answer | Actuators:
    """Validate a decoded client map; unknown types are refused with `unknown_type`."""
    kind = body["type"]
    parser = CLIENT_MESSAGES.get(kind)
    if parser is None:
        raise WireError("unknown_type", f"unknown message type {echo(kind)}; expected one of {', '.join(CLIENT_MESSAGES)}")
    return parser.parse(body)


IDENTITY_FIELDS = ("token_id", "role", "site", "session")  # what a welcome says of a token (never the secret)


def welcome(client_id: int, role: str, server: str, tick_hz: int, state_hz: float, fmt: str,
            identity: Mapping[str, Any] | None = None) -> dict:
    msg = {"type": "welcome", "v": PROTOCOL_VERSION, "minor": PROTOCOL_MINOR, "client_id": client_id,
           "role": role, "server": server, "tick_hz": tick_hz, "state_hz": state_hz, "format": fmt}
    if identity is not None:
        msg["identity"] = {k: identity.get(k) for k in IDENTITY_FIELDS}
    return msg


def scene_message(scene: dict, scene_hash: str) -> dict:
    return {"type": "scene", "v": SCENE_FORMAT_VERSION, "hash": scene_hash, "scene": scene}


HUB_STATE_FIELDS = ("actuator",)  # added by the hub, not the loop's view (v1.6: server/hub/browser_actuators.py)
_STATE_FIELDS = tuple(f.name for f in STATE.fields[1:] if f.name not in HUB_STATE_FIELDS)  # after `type`
# Events per state frame on the wire: all of them normally (a few a second); a flood (many
# clients' inputs, a runaway scenario) keeps the newest, dropping `input` events first, so no
# client can grow every viewer's frames without bound. The recorder reads the loop's record, which
# keeps every event (docs/protocol.md "Input budget").
MAX_WIRE_EVENTS = 32


def wire_events(events: list) -> list:
    """At most MAX_WIRE_EVENTS of `events`, in their order: the oldest `input` events go first,
    then the oldest others. `events` itself is not changed."""
    excess = len(events) - MAX_WIRE_EVENTS
    if excess <= 0:
        return events
    drop = set()
    for i, event in enumerate(events):
        if len(drop) == excess:
            break
        if isinstance(event, Mapping) and event.get("name") == "input":
            drop.add(i)
    kept = [e for i, e in enumerate(events) if i not in drop]
    return kept[len(kept) - MAX_WIRE_EVENTS:]


def state_message(view: Mapping[str, Any], telemetry: dict, actuator: list | None = None) -> dict:
    """The wire `state` for the client view of a loop state record (server/ipc/records.py
    State.view: every declared field but `type`, `telemetry` and `actuator`, in their order): `type`
    first, `telemetry` in its place, the events capped (wire_events), and `actuator` last when the
    rig has a browser device (v1.6). KeyError naming a field the view lacks."""
    msg: dict[str, Any] = {"type": "state"}
    for name in _STATE_FIELDS:
        msg[name] = telemetry if name == "telemetry" else view[name]
    msg["events"] = wire_events(msg["events"])
    if actuator is not None:
        msg["actuator"] = actuator
    return msg


def error(code: str, message: str) -> dict:
    """The `error` message; every error text a client is sent is built here, so its bound holds for
    all of them: a text longer than MAX_ERROR_MESSAGE_CHARS is cut (values quoted from the client
    are cut shorter already, codec.echo)."""
    if len(message) > MAX_ERROR_MESSAGE_CHARS:
        message = message[:MAX_ERROR_MESSAGE_CHARS - 1] + "…"
    return {"type": "error", "code": code, "message": message}



def health(status: str, reasons: list[Mapping[str, Any]]) -> dict:
    """The `health` message: the status and each reason's code and message (no `since_s`: it would
    change the frame every time without news)."""
    return {"type": "health", "status": status,
            "reasons": [{"code": r["code"], "message": r["message"]} for r in reasons]}


def lease(snapshot: Mapping[str, Any]) -> dict:
    """The `lease` message for a lease snapshot (server/auth/lease.py `Lease.snapshot()`), the
    declared fields in their order."""
    return {"type": "lease", "holder": snapshot.get("holder"), "queue": list(snapshot.get("queue") or []),
            "session": snapshot.get("session"), "ttl_s": snapshot["ttl_s"]}


def ask(view: Mapping[str, Any]) -> dict:
    """The `ask` message for a participant view (server/experiment/participant.py), the declared
    fields in their order."""
    return {"type": "ask", "session": view["session"], "seq": view.get("seq"), "task": view.get("task"),
            "questions": [dict(q) for q in view.get("questions") or []],
            "audio": {"speech": bool((view.get("audio") or {}).get("speech")),
                      "contact_sounds": bool((view.get("audio") or {}).get("contact_sounds"))},
            "instructions": view.get("instructions") or "",
            "pacing": None if view.get("pacing") is None else dict(view["pacing"])}
