"""Check a decoded message against its declaration (schema.py); the browser's checker in
clients/web/src/protocol.js reads the same declaration and answers with the same codes.

`check_message` returns the declared fields with receiver-side values: integers as int (an
integral float such as 3.0 counts as 3), other numbers as float, vectors as tuples of floats, a
quaternion divided by its norm, optional fields that are absent or null as their default.
Fields not declared are ignored (minor additions). A wrong field is WireError("bad_message")
naming it; NaN or +-Infinity is WireError("non_finite") (the decoder already refuses those in
frames; this catches maps built in Python); a finite number beyond the protocol's bounds (an
integer outside +-(2**53 - 1), a number or vector component beyond the type's `max_abs`, such as
a tracker position outside the workspace) is WireError("out_of_range").

Each type is compiled once into a closure: tracker messages are parsed in the loop process (the
UDP tracker port), up to 32 a tick.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any, Callable

from server.core.numbers import is_finite_number, is_number
from server.wire.codec import WireError, echo
from server.wire.schema import MAX_SAFE_INT, MESSAGES, Message

Check = Callable[[Any, str], Any]  # (value, path) -> receiver-side value


class _Mismatch(Exception):
    """A value that does not fit a type; becomes bad_message naming the field."""


def _plain(doc: str) -> str:
    return doc.replace("`", "").replace("\\|", "|")


def _finite(value: Any, path: str) -> int | float:
    if not is_number(value):
        raise _Mismatch
    if not is_finite_number(value):  # NaN, infinity, or an int too long for a float
        raise WireError("non_finite", f"'{path}' must be a finite number")
    return value


def _bounds(t: dict) -> Callable[[float], bool]:
    low, high, open_low = t.get("min"), t.get("max"), t.get("min_exclusive", False)
    low = -math.inf if low is None else low
    high = math.inf if high is None else high
    if open_low:
        return lambda v: low < v <= high
    return lambda v: low <= v <= high


def _out_of_range(path: str, limit: float, what: str = "") -> WireError:
    return WireError("out_of_range", f"'{path}' must {what}lie within ±{limit:g}")


def _int(t: dict) -> Check:
    inside = _bounds(t)

    def check(value: Any, path: str) -> int:
        value = _finite(value, path)
        if isinstance(value, float):
            if not value.is_integer():
                raise _Mismatch
            value = int(value)
        if abs(value) > MAX_SAFE_INT:  # beyond what JavaScript (and a float64) holds exactly
            raise WireError("out_of_range", f"'{path}' must be an integer within ±(2^53 − 1)")
        if not inside(value):
            raise _Mismatch
        return value
    return check


def _number(t: dict) -> Check:
    inside = _bounds(t)
    limit = t.get("max_abs")

    def check(value: Any, path: str) -> float:
        value = float(_finite(value, path))
        if limit is not None and not -limit <= value <= limit:
            raise _out_of_range(path, limit)
        if not inside(value):
            raise _Mismatch
        return value
    return check


def _string(t: dict) -> Check:
    low, high = t.get("min_len", 0), t.get("max_len", math.inf)

    def check(value: Any, path: str) -> str:
        if not isinstance(value, str) or not low <= len(value) <= high:
            raise _Mismatch
        return value
    return check


def _numbers(value: Any, size: int, path: str) -> tuple[float, ...]:
    if not isinstance(value, (list, tuple)) or len(value) != size:
        raise _Mismatch
    out = []
    for v in value:
        if v.__class__ is float:  # the common case first: the path is spelt only for an error
            if not math.isfinite(v):
                raise WireError("non_finite", f"'{path}' must contain finite numbers")
        elif not is_number(v):
            raise _Mismatch
        elif not is_finite_number(v):  # an int too long for a float
            raise WireError("non_finite", f"'{path}' must contain finite numbers")
        out.append(float(v))
    return tuple(out)


def _vec(t: dict) -> Check:
    size = t["size"]
    inside = _bounds(t)
    bounded = "min" in t or "max" in t
    limit = t.get("max_abs")

    def check(value: Any, path: str) -> tuple[float, ...]:
        out = _numbers(value, size, path)
        if limit is not None and not all(-limit <= v <= limit for v in out):
            raise _out_of_range(path, limit, "have every component ")
        if bounded and not all(inside(v) for v in out):
            raise _Mismatch
        return out
    return check


def _quat(t: dict) -> Check:
    low, high = t["norm"]

    def check(value: Any, path: str) -> tuple[float, ...]:
        q = _numbers(value, 4, path)
        norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        if not low <= norm <= high:
            raise _Mismatch
        return (q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm)
    return check


def _array(t: dict) -> Check:
    item = compile_type(t["items"])

    def check(value: Any, path: str) -> list:
        if not isinstance(value, (list, tuple)):
            raise _Mismatch
        return [item(v, f"{path}[{i}]") for i, v in enumerate(value)]
    return check


def _tuple(t: dict) -> Check:
    items = [compile_type(it) for it in t["items"]]

    def check(value: Any, path: str) -> list:
        if not isinstance(value, (list, tuple)) or len(value) != len(items):
            raise _Mismatch
        return [c(v, f"{path}[{i}]") for i, (v, c) in enumerate(zip(value, items))]
    return check


def _map(t: dict) -> Check:
    values = compile_type(t["values"]) if "values" in t else None
    keys = compile_type(t["keys"]) if "keys" in t else None

    def check(value: Any, path: str) -> dict:
        if not isinstance(value, dict) or not all(isinstance(k, str) for k in value):
            raise _Mismatch
        if keys is not None:
            for k in value:
                keys(k, f"{path} key {k[:64]!r}")
        return value if values is None else {k: values(v, f"{path}.{k}") for k, v in value.items()}
    return check


def _any_of(t: dict) -> Check:
    options = [compile_type(o) for o in t["types"]]

    def check(value: Any, path: str) -> Any:
        for option in options:
            try:
                return option(value, path)
            except WireError as exc:
                if exc.code != "bad_message":
                    raise  # NaN is never valid, whichever option it was meant for
        raise _Mismatch
    return check


def _when(predicate: Callable[[Any, dict], bool]) -> Callable[[dict], Check]:
    def make(t: dict) -> Check:
        def check(value: Any, path: str) -> Any:
            if not predicate(value, t):
                raise _Mismatch
            return value
        return check
    return make


_KINDS: dict[str, Callable[[dict], Check]] = {
    "int": _int, "number": _number, "string": _string, "vec": _vec, "quat": _quat, "array": _array,
    "tuple": _tuple, "map": _map, "any_of": _any_of,
    "bool": _when(lambda v, t: isinstance(v, bool)),
    "null": _when(lambda v, t: v is None),
    "enum": _when(lambda v, t: isinstance(v, str) and v in t["values"]),
    "const": _when(lambda v, t: v == t["value"]),
}


def compile_type(t: dict) -> Check:
    """A checker for type `t` (schema.py): WireError naming the path when a value does not fit."""
    inner = _KINDS[t["kind"]](t)
    expected = _plain(t["doc"])

    def check(value: Any, path: str) -> Any:
        try:
            return inner(value, path)
        except _Mismatch:
            raise WireError("bad_message", f"'{path}' must be {expected}") from None
    return check


@lru_cache(maxsize=None)
def _compiled(name: str) -> tuple[tuple[str, bool, Any, Check, str], ...]:
    return tuple((f.name, f.required, f.default, compile_type(f.type), _plain(f.type["doc"]))
                 for f in MESSAGES[name].fields[1:])


def check_message(body: dict, message: Message | None = None) -> dict[str, Any]:
    """The declared fields of a decoded map (see module docstring); WireError when one is wrong,
    `unknown_type` for a type that is not declared."""
    name = body.get("type") if message is None else message.name
    if name not in MESSAGES:
        raise WireError("unknown_type", f"unknown message type {echo(name)}; expected one of {', '.join(MESSAGES)}")
    out: dict[str, Any] = {}
    for field, required, default, check, expected in _compiled(name):
        value = body.get(field)
        if value is None and (not required or field not in body):
            if required:
                raise WireError("bad_message", f"'{field}' is missing: it must be {expected}")
            out[field] = default
            continue
        out[field] = check(value, field)
    return out
