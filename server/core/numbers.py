"""What counts as a number for every validator: an int or a float but not a bool (Python counts
True as 1, and a JSON `true` must not pass for 1), and a finite one is neither NaN nor infinite.

Each caller keeps its own error type and message; these only answer yes or no."""

from __future__ import annotations

import math
from typing import Any


def is_number(value: Any) -> bool:
    """An int or a float, not a bool."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def is_finite_number(value: Any) -> bool:
    """A number (is_number) that is neither NaN nor infinite, and fits a float."""
    if not is_number(value):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:  # an int too long for a float (JSON allows any length): no use as a number here
        return False
