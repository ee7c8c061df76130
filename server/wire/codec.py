"""Wire codec for protocol v1: bytes/text <-> plain maps. Pure functions, no I/O.

Theory of operation (docs/protocol.md, "Encoding"):
- msgpack binary frames by default, JSON text frames when the client asked for the
  `viestac.v1.json` subprotocol;
- numbers are canonical (server/core/canonical_json.py owns the rule): an integral value below
  2**53 is written as an integer, every other number as float64. JavaScript encoders do that by
  themselves, so with this rule the Python and JS codecs produce the same bytes for the same
  message (checked by tests/vectors/);
- NaN and +-Infinity are never valid, in either direction, anywhere in a frame (known field or
  not; JSON's 1e999 is infinity too), and neither is an integer too long for a float64;
- the size limit counts encoded bytes in both encodings (a JSON text frame as UTF-8);
- maps and arrays nest at most MAX_DEPTH deep (checked without recursion, so no frame can reach
  Python's recursion limit);
- every failure is a `WireError` carrying a protocol error code, never a bare exception, so the
  hub can answer with one `error` frame and keep the connection.
"""

from __future__ import annotations

import json
import sys
from math import isfinite
from typing import Any

import msgpack

from server.core.canonical_json import NonFiniteNumber, canonical_numbers

FORMATS = ("msgpack", "json")
SUBPROTOCOLS = {"viestac.v1.msgpack": "msgpack", "viestac.v1.json": "json"}
MAX_FRAME_BYTES = 64 * 1024
MAX_DEPTH = 32  # maps and arrays nested in a frame; a client message needs 2, a scene 7
_MAX_FLOAT_INT = int(sys.float_info.max)  # a longer integer has no float64 value
_MAX_INT_DIGITS = len(str(_MAX_FLOAT_INT)) + 1  # JSON integer text longer than this is refused unparsed
TOO_DEEP = f"maps and arrays may nest at most {MAX_DEPTH} deep"


MAX_ECHO_CHARS = 64  # a client's value quoted in an error: enough to recognise it, never all of a flood


def echo(value: Any) -> str:
    """`value` as an error text quotes it back to its sender (repr), cut to MAX_ECHO_CHARS
    characters: a reply never grows with what the client sent."""
    if isinstance(value, (str, bytes)) and len(value) > MAX_ECHO_CHARS:
        return f"{value[:MAX_ECHO_CHARS]!r}… ({len(value)} characters)"
    text = repr(value)
    return text if len(text) <= MAX_ECHO_CHARS else f"{text[:MAX_ECHO_CHARS]}… ({len(text)} characters)"


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


def _json_int(text: str) -> int:
    if len(text) > _MAX_INT_DIGITS:  # parsing it could take long (and raises past 4300 digits)
        raise WireError("non_finite", f"an integer of {len(text)} digits has no float64 value")
    return int(text)


def _check_body(body: Any) -> None:
    """Every number finite and float64-sized, nesting at most MAX_DEPTH: iterative, so a deeply
    nested frame cannot reach the recursion limit."""
    stack = [(body, 1)]
    while stack:
        value, depth = stack.pop()
        items = value.values() if value.__class__ is dict else value
        for v in items:
            cls = v.__class__
            if cls is float:
                if not isfinite(v):
                    raise WireError("non_finite", "NaN and Infinity are not valid numbers")
            elif cls is int:
                if v > _MAX_FLOAT_INT or v < -_MAX_FLOAT_INT:
                    raise WireError("non_finite", "an integer too long for a float64 is not a valid number")
            elif cls is dict or cls is list:
                if depth >= MAX_DEPTH:
                    raise WireError("bad_message", TOO_DEEP)
                stack.append((v, depth + 1))


def frame_size(data: bytes | str) -> int:
    """Encoded bytes of a frame: a text frame counts as its UTF-8 bytes (up to 4 per character)."""
    if isinstance(data, str):
        n = len(data)
        return n if n * 4 <= MAX_FRAME_BYTES or n > MAX_FRAME_BYTES else len(data.encode("utf-8", "surrogatepass"))
    return len(data)


def decode(data: bytes | str, fmt: str = "msgpack") -> dict:
    """Decode one frame into a message map with a string `type`; raise WireError otherwise."""
    size = frame_size(data)
    if size > MAX_FRAME_BYTES:
        raise WireError("too_large", f"frame of {size} bytes exceeds {MAX_FRAME_BYTES}")
    if fmt == "msgpack":
        if isinstance(data, str):
            raise WireError("bad_encoding", "text frame on a msgpack connection")
        try:
            body = msgpack.unpackb(data, raw=False, strict_map_key=True)
        except msgpack.StackError:
            raise WireError("bad_message", TOO_DEEP) from None
        except (ValueError, msgpack.UnpackException, TypeError) as exc:
            raise WireError("bad_encoding", f"not a valid msgpack frame: {exc}") from None
    elif fmt == "json":
        if isinstance(data, (bytes, bytearray)):
            raise WireError("bad_encoding", "binary frame on a JSON connection")
        try:
            body = json.loads(data, parse_constant=_reject_constant, parse_int=_json_int)
        except RecursionError:
            raise WireError("bad_message", TOO_DEEP) from None
        except ValueError as exc:  # JSONDecodeError, and a lone surrogate's UnicodeEncodeError
            raise WireError("bad_encoding", f"not valid JSON: {exc}") from None
    else:
        raise ValueError(f"unknown wire format {fmt!r}; expected one of {FORMATS}")
    if body.__class__ is dict or body.__class__ is list:
        _check_body(body)
    if not isinstance(body, dict):
        raise WireError("bad_message", "a message must be a map")
    kind = body.get("type")
    if not isinstance(kind, str):
        raise WireError("bad_message", "a message needs a string field 'type'")
    return body
