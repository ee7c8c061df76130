"""Which haptic core runs: the compiled one (``_chaptics.c``) when the package build made it, else the
Python reference with a warning.

The Python modules (primitives.py, god_object.py, contact_gate.py) are the specification: the C
transcribes them operation for operation and tests/haptics/test_compiled.py checks that both give
the same numbers. A missing extension is therefore a speed problem, not a correctness one (the
reference is ~20x slower per tick and still inside the 1 kHz budget on the thesis scenes), so it
is a warning and not a hard error: a checkout whose build was skipped still runs and tests.
"""

from __future__ import annotations

import warnings
from types import ModuleType

CORE_VERSION = 1  # must equal _chaptics.VERSION: a stale build of an older C source is not used


def _load() -> ModuleType | None:
    try:
        from . import _chaptics  # type: ignore[attr-defined]
    except ImportError as e:
        warnings.warn(f"the compiled haptic core is not built ({e}); using the Python reference "
                      "(same results, ~20x the cost per tick). `pip install -e .` (scripts/setup.sh) "
                      "builds it.", RuntimeWarning, stacklevel=3)
        return None
    if getattr(_chaptics, "VERSION", None) != CORE_VERSION:
        warnings.warn(f"the compiled haptic core is stale (version {getattr(_chaptics, 'VERSION', None)}, "
                      f"want {CORE_VERSION}); using the Python reference. Rebuild: `pip install -e .`.",
                      RuntimeWarning, stacklevel=3)
        return None
    return _chaptics


chaptics = _load()
COMPILED = chaptics is not None
