"""Protocol v1 messages (docs/protocol.md): validated client messages, server message builders.

Client messages are frozen dataclasses that validate themselves when parsed from a decoded map
(h11 style): a wrong field is a `WireError("bad_message", ...)` naming the field. Server
messages are built as maps whose key order is the documented field order, because the msgpack
test vectors are byte-exact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from server.wire.codec import WireError

PROTOCOL_VERSION = 1
ROLES = ("participant", "operator", "observer")
INPUT_ACTIONS = ("down", "up", "press")
_MAX_NAME = 64
_MAX_KEY = 32


def _number(body: dict, field: str) -> float:
    value = body.get(field)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise WireError("bad_message", f"'{field}' must be a number")
    if not math.isfinite(value):
        raise WireError("non_finite", f"'{field}' must be finite")
    return float(value)


def _vector(body: dict, field: str, size: int) -> tuple[float, ...]:
    value = body.get(field)
    if not isinstance(value, list) or len(value) != size:
        raise WireError("bad_message", f"'{field}' must be an array of {size} numbers")
    out = []
    for item in value:
        if isinstance(item, bool) or not isinstance(item, (int, float)):
            raise WireError("bad_message", f"'{field}' must be an array of {size} numbers")
        if not math.isfinite(item):
            raise WireError("non_finite", f"'{field}' must contain finite numbers")
        out.append(float(item))
    return tuple(out)


def _string(body: dict, field: str, max_len: int, choices: tuple[str, ...] = ()) -> str:
    value = body.get(field)
    if not isinstance(value, str) or not value or len(value) > max_len:
        raise WireError("bad_message", f"'{field}' must be a string of 1..{max_len} characters")
    if choices and value not in choices:
        raise WireError("bad_message", f"'{field}' must be one of {', '.join(choices)}")
    return value


@dataclass(frozen=True)
class Hello:
    version: int
    role: str
    client: str

    @classmethod
    def parse(cls, body: dict) -> Hello:
        version = body.get("v")
        if isinstance(version, bool) or not isinstance(version, int):
            raise WireError("bad_message", "'v' must be an integer protocol version")
        role = _string(body, "role", 16, ROLES)
        client = body.get("client", "")
        if not isinstance(client, str) or len(client) > _MAX_NAME:
            raise WireError("bad_message", f"'client' must be a string of at most {_MAX_NAME} characters")
        return cls(version, role, client)

    def to_wire(self) -> dict:
        return {"type": "hello", "v": self.version, "role": self.role, "client": self.client}


@dataclass(frozen=True)
class Tracker:
    seq: int
    t_ms: float
    pos: tuple[float, float, float]
    quat: tuple[float, float, float, float] | None = None

    @classmethod
    def parse(cls, body: dict) -> Tracker:
        seq = body.get("seq")
        if isinstance(seq, bool) or not isinstance(seq, int) or seq < 0:
            raise WireError("bad_message", "'seq' must be an integer >= 0")
        t_ms = _number(body, "t")
        pos = _vector(body, "pos", 3)
        quat = None
        if body.get("quat") is not None:
            quat = _vector(body, "quat", 4)
            if math.sqrt(sum(q * q for q in quat)) < 1e-9:
                raise WireError("bad_message", "'quat' must be a non-zero quaternion [w, x, y, z]")
        return cls(seq, t_ms, pos, quat)  # type: ignore[arg-type]

    def to_wire(self) -> dict:
        msg: dict[str, Any] = {"type": "tracker", "seq": self.seq, "t": self.t_ms, "pos": list(self.pos)}
        if self.quat is not None:
            msg["quat"] = list(self.quat)
        return msg


@dataclass(frozen=True)
class Input:
    key: str
    action: str
    value: bool | float | str | None = None  # a command's argument, e.g. tap_angle 30

    @classmethod
    def parse(cls, body: dict) -> Input:
        value = body.get("value")
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            value = _number(body, "value")
        elif value is not None and not isinstance(value, bool) and not (isinstance(value, str) and len(value) <= 200):
            raise WireError("bad_message", "'value' must be a number, a boolean or a string of at most 200 characters")
        return cls(_string(body, "key", _MAX_KEY), _string(body, "action", 8, INPUT_ACTIONS), value)

    def to_wire(self) -> dict:
        msg: dict[str, Any] = {"type": "input", "key": self.key, "action": self.action}
        if self.value is not None:
            msg["value"] = self.value
        return msg


CLIENT_MESSAGES = {"hello": Hello, "tracker": Tracker, "input": Input}


def parse_client_message(body: dict) -> Hello | Tracker | Input:
    """Validate a decoded client map; unknown types are refused with `unknown_type`."""
    kind = body["type"]
    parser = CLIENT_MESSAGES.get(kind)
    if parser is None:
        raise WireError("unknown_type", f"unknown message type {kind!r}; expected one of {', '.join(CLIENT_MESSAGES)}")
    return parser.parse(body)


def welcome(client_id: int, role: str, server: str, tick_hz: int, state_hz: float, fmt: str) -> dict:
    return {"type": "welcome", "v": PROTOCOL_VERSION, "client_id": client_id, "role": role,
            "server": server, "tick_hz": tick_hz, "state_hz": state_hz, "format": fmt}


def scene_message(scene: dict, scene_hash: str) -> dict:
    return {"type": "scene", "v": PROTOCOL_VERSION, "hash": scene_hash, "scene": scene}


def state_message(*, frame: int, tick: int, t: float, scene: str, hip, proxy, force, contact: bool,
                  contacts, objects, cues, hud: str, values: dict, telemetry: dict, visible: dict | None = None,
                  events: list | None = None, scales: dict | None = None) -> dict:
    return {"type": "state", "frame": frame, "tick": tick, "t": t, "scene": scene,
            "hip": list(hip), "proxy": list(proxy), "force": list(force), "contact": contact,
            "contacts": contacts, "objects": objects, "cues": cues, "hud": hud, "values": values,
            "telemetry": telemetry, "visible": visible or {}, "events": events or [], "scales": scales or {}}


def error(code: str, message: str) -> dict:
    return {"type": "error", "code": code, "message": message}
