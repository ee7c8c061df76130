"""Seeded random draws for synthetic participants, reproducible in any process.

Every draw comes from its own `numpy.random.default_rng`, seeded from the SHA-256 of the
draw's identity (the study-level seed, the participant, the trial's seq, what is drawn). The
same identity gives the same numbers on any machine, in any process and in any call order;
Python's `hash()` (salted per process for strings) is never used.
"""

from __future__ import annotations

import hashlib
import json

import numpy as np


def seed_from(*parts: int | float | str | None) -> int:
    """A 128-bit integer seed from the parts (ints, floats, strings): the first 16 bytes of the
    SHA-256 of their JSON text. `seed_from(1, 2)` and `seed_from("1", 2)` differ."""
    text = json.dumps(list(parts), separators=(",", ":"), allow_nan=False)
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:16], "big")


def derive_rng(*parts: int | float | str | None) -> np.random.Generator:
    """A fresh generator for the draw these parts name, e.g. (seed, participant, seq, "rating")."""
    return np.random.default_rng(seed_from(*parts))
