"""Wire codec for protocol v1: bytes/text <-> plain maps. Pure functions, no I/O.

Theory of operation (docs/protocol.md, "Encoding"):
- msgpack binary frames by default, JSON text frames when the client asked for the
  `viestac.v1.json` subprotocol;
- numbers are canonical (server/core/canonical_json.py owns the rule): an integral value below
  2**53 is written as an integer, every other number as float64. JavaScript encoders do that by
  themselves, so with this rule the Python and JS codecs produce the same bytes for the same
  message (checked by tests/vectors/);
- NaN and +-Infinity are never valid, in either direction;
- every failure is a `WireError` carrying a protocol error code, never a bare exception, so the
  hub can answer with one `error` frame and keep the connection.
"""

from __future__ import annotations

import json
import math
from typing import Any

import msgpack

from server.core.canonical_json import NonFiniteNumber, canonical_numbers

FORMATS = ("msgpack", "json")
SUBPROTOCOLS = {"viestac.v1.msgpack": "msgpack", "viestac.v1.json": "json"}
MAX_FRAME_BYTES = 64 * 1024


class WireError(Exception):
    """A frame the protocol refuses; `code` is one of the protocol's error codes."""

    def __init__(self, code: str, message: str):
        super().__init__(message)
        self.code = code
        self.message = message


def canonical(value: Any) -> Any:
    """Return `value` with canonical numbers (see module docstring); raise on non-finite."""
    try:
        return canonical_numbers(value)
    except NonFiniteNumber as exc:
        raise WireError("non_finite", str(exc)) from None


def encode(message: dict, fmt: str = "msgpack") -> bytes | str:
    """Encode one message map; msgpack gives bytes, json gives str."""
    body = canonical(message)
    if fmt == "msgpack":
        return msgpack.packb(body, use_bin_type=True)
    if fmt == "json":
        return json.dumps(body, separators=(",", ":"), ensure_ascii=False, allow_nan=False)
    raise ValueError(f"unknown wire format {fmt!r}; expected one of {FORMATS}")


def _reject_constant(name: str) -> Any:
    raise WireError("non_finite", f"{name} is not a valid number")


def _check_finite(value: Any) -> None:
    if isinstance(value, float):
        if not math.isfinite(value):
            raise WireError("non_finite", "NaN and Infinity are not valid numbers")
    elif isinstance(value, dict):
        for v in value.values():
            _check_finite(v)
    elif isinstance(value, list):
        for v in value:
            _check_finite(v)


def decode(data: bytes | str, fmt: str = "msgpack") -> dict:
    """Decode one frame into a message map with a string `type`; raise WireError otherwise."""
    if len(data) > MAX_FRAME_BYTES:
        raise WireError("too_large", f"frame of {len(data)} bytes exceeds {MAX_FRAME_BYTES}")
    if fmt == "msgpack":
        if isinstance(data, str):
            raise WireError("bad_encoding", "text frame on a msgpack connection")
        try:
            body = msgpack.unpackb(data, raw=False, strict_map_key=True)
        except (ValueError, msgpack.UnpackException, TypeError) as exc:
            raise WireError("bad_encoding", f"not a valid msgpack frame: {exc}") from None
        _check_finite(body)
    elif fmt == "json":
        if isinstance(data, (bytes, bytearray)):
            raise WireError("bad_encoding", "binary frame on a JSON connection")
        try:
            body = json.loads(data, parse_constant=_reject_constant)
        except json.JSONDecodeError as exc:
            raise WireError("bad_encoding", f"not valid JSON: {exc}") from None
    else:
        raise ValueError(f"unknown wire format {fmt!r}; expected one of {FORMATS}")
    if not isinstance(body, dict):
        raise WireError("bad_message", "a message must be a map")
    kind = body.get("type")
    if not isinstance(kind, str):
        raise WireError("bad_message", "a message needs a string field 'type'")
    return body
