"""The "did you mean" hint every validator of a file or a table adds to an unknown name (the study
TOML, the psychophysical procedure specs): the closest known name by difflib, or the known names."""

from __future__ import annotations

import difflib
from typing import Iterable


def did_you_mean(name: str, known: Iterable) -> str:
    """` (did you mean 'x'?)` for the closest of `known`, else ` (known: a, b, c)`."""
    known = list(known)
    close = difflib.get_close_matches(str(name), [str(k) for k in known], n=1)
    return f" (did you mean {close[0]!r}?)" if close else f" (known: {', '.join(map(str, known))})"
