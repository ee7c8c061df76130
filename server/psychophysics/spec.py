"""Reading a procedure spec from a plain dict (as a study TOML table gives it): unknown fields get
a "did you mean", missing and wrongly typed ones name the field, and every error starts with
where the table is (e.g. `procedure "low"`), so a lab can fix the file without reading code."""

from __future__ import annotations

import math
from typing import Any, Mapping

from server.core.did_you_mean import did_you_mean

_REQUIRED = object()


class SpecError(ValueError):
    """A procedure spec that cannot be run (unknown, missing or wrong fields; cannot converge)."""


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


class Fields:
    """One table of a spec: reads each field once, then `done()` refuses the ones nobody read."""

    def __init__(self, table: Any, where: str):
        if not isinstance(table, Mapping):
            raise SpecError(f"{where}: expected a table, got {type(table).__name__}")
        self.table, self.where, self.read = table, where, set()

    def error(self, field: str | None, text: str) -> SpecError:
        return SpecError(f"{self.where}: {field}: {text}" if field else f"{self.where}: {text}")

    def _get(self, name: str, default):
        self.read.add(name)
        if name not in self.table:
            if default is _REQUIRED:
                raise self.error(name, "missing (required)")
            return default, False
        return self.table[name], True

    def number(self, name: str, default=_REQUIRED, *, low=None, high=None, low_open=False, whole=False):
        value, given = self._get(name, default)
        if not given:
            return value
        if not _is_number(value) or (whole and not isinstance(value, int)):
            raise self.error(name, f"expected {'a whole number' if whole else 'a finite number'}, got {value!r}")
        if low is not None and (value < low or (low_open and value == low)):
            raise self.error(name, f"must be {'>' if low_open else '≥'} {low}, got {value!r}")
        if high is not None and value > high:
            raise self.error(name, f"must be ≤ {high}, got {value!r}")
        return value

    def numbers(self, name: str, default=_REQUIRED, *, positive=False, min_len=1) -> tuple:
        value, given = self._get(name, default)
        if not given:
            return value
        if _is_number(value):
            value = [value]
        if not isinstance(value, (list, tuple)) or len(value) < min_len or not all(map(_is_number, value)):
            raise self.error(name, f"expected a list of at least {min_len} finite numbers, got {value!r}")
        if positive and any(v <= 0 for v in value):
            raise self.error(name, f"every value must be > 0, got {value!r}")
        return tuple(float(v) for v in value)

    def choice(self, name: str, allowed, default=_REQUIRED):
        value, given = self._get(name, default)
        if given and value not in allowed:
            raise self.error(name, f"unknown value {value!r}{did_you_mean(str(value), allowed)}")
        return value

    def text(self, name: str, default=_REQUIRED) -> str:
        value, given = self._get(name, default)
        if given and not isinstance(value, str):
            raise self.error(name, f"expected a string, got {value!r}")
        return value

    def table_of(self, name: str, default=_REQUIRED):
        value, given = self._get(name, default)
        if given and not isinstance(value, Mapping):
            raise self.error(name, f"expected a table, got {value!r}")
        return value

    def done(self) -> None:
        for name in self.table:
            if name not in self.read:
                raise self.error(None, f"unknown field {name!r}{did_you_mean(str(name), sorted(self.read))}")
