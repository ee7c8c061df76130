"""Canonical numbers and canonical JSON: the one owner of both rules (docs/protocol.md).

- Canonical numbers (the wire's rule): a number whose value is integral and whose magnitude is
  below 2**53 is an integer, every other number a float64; NaN and +-Infinity are refused. This is
  what a JavaScript encoder does by itself, so every codec writes the same msgpack bytes.
- Canonical JSON is RFC 8785 (JSON Canonicalization Scheme) applied to the canonical-number form:
  keys sorted by UTF-16 code units, no whitespace, strings escaped as ECMAScript's JSON.stringify
  does (only `"`, `\\` and control characters), numbers in ECMAScript's Number-to-string form
  (shortest round-trip digits; exponent form below 1e-6 and from 1e21 on). A JavaScript client gets
  the same text from JSON.stringify with sorted keys, so the scene hash (server/core/scene.py) can
  be recomputed from the scene map a client received, whatever its encoding.
"""

from __future__ import annotations

import math
from json.encoder import encode_basestring  # C-accelerated; escapes exactly what RFC 8785 escapes
from typing import Any

MAX_SAFE_INT = 2**53


class NonFiniteNumber(ValueError):
    """NaN or +-Infinity: never a valid number on the wire or in a canonical form."""


def canonical_numbers(value: Any) -> Any:
    """`value` with canonical numbers (tuples become lists); NonFiniteNumber on NaN/Infinity."""
    if isinstance(value, float):
        if not math.isfinite(value):
            raise NonFiniteNumber("NaN and Infinity are not valid numbers")
        if value.is_integer() and abs(value) < MAX_SAFE_INT:
            return int(value)
        return value
    if isinstance(value, dict):
        return {k: canonical_numbers(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [canonical_numbers(v) for v in value]
    return value


def es_number(x: float) -> str:
    """A finite float as ECMAScript's Number::toString writes it (RFC 8785 section 3.2.2.3)."""
    if x == 0:
        return "0"  # also -0
    text = repr(x)  # shortest round-trip digits, as ECMAScript's
    if "e" not in text:  # Python's plain range [1e-4, 1e16) lies inside ECMAScript's [1e-6, 1e21)
        return text[:-2] if text.endswith(".0") else text
    sign = "-" if x < 0 else ""
    mantissa, _, exponent = text.lstrip("-").partition("e")
    whole, _, fraction = mantissa.partition(".")
    digits = (whole + fraction).rstrip("0")
    n = len(whole) + int(exponent)  # x = 0.digits * 10**n (whole is one non-zero digit here)
    k = len(digits)
    if k <= n <= 21:
        body = digits + "0" * (n - k)
    elif 0 < n <= 21:
        body = digits[:n] + "." + digits[n:]
    elif -6 < n <= 0:
        body = "0." + "0" * -n + digits
    else:
        e = n - 1
        body = (digits[0] + ("." + digits[1:] if k > 1 else "")) + "e" + ("+" if e >= 0 else "-") + str(abs(e))
    return sign + body


def _utf16(key: str) -> bytes:
    return key.encode("utf-16-be", "surrogatepass")


def _write(value: Any, out: list[str]) -> None:
    if value is None:
        out.append("null")
    elif value is True:
        out.append("true")
    elif value is False:
        out.append("false")
    elif isinstance(value, str):
        out.append(encode_basestring(value))
    elif isinstance(value, int):
        # beyond 2**53 a JSON number is a double, as a JavaScript reader holds it
        out.append(str(value) if abs(value) < MAX_SAFE_INT else es_number(float(value)))
    elif isinstance(value, float):
        out.append(es_number(value))
    elif isinstance(value, dict):
        out.append("{")
        for i, key in enumerate(sorted(value, key=_utf16)):
            if not isinstance(key, str):
                raise TypeError(f"canonical JSON keys must be strings, not {type(key).__name__}")
            if i:
                out.append(",")
            out.append(encode_basestring(key))
            out.append(":")
            _write(value[key], out)
        out.append("}")
    elif isinstance(value, list):
        out.append("[")
        for i, item in enumerate(value):
            if i:
                out.append(",")
            _write(item, out)
        out.append("]")
    else:
        raise TypeError(f"{type(value).__name__} has no canonical JSON form")


def canonical_json(value: Any) -> str:
    """RFC 8785 text of `value` after canonical_numbers (NonFiniteNumber on NaN/Infinity)."""
    out: list[str] = []
    _write(canonical_numbers(value), out)
    return "".join(out)
