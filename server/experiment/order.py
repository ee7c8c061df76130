"""Presentation orders: fixed, seeded pseudo-random, and balanced Latin squares (pure functions).

Every order is a list of indices into the items being ordered (a task's conditions, a block's
tasks), computed from the participant's index and the study's seed only, so the same study file
gives the same session to the same participant on any machine, in any Python process:

- "fixed": the items in file order.
- "random": a permutation from `random.Random(seed)`, where the seed is derived from
  `seed_parts` with SHA-256. Python's `hash()` is salted per process (PYTHONHASHSEED), so it is
  never used; `random.Random(int)` and `shuffle` are documented to be reproducible across
  versions and platforms for a given integer seed.
- "latin": row `participant_index % len(rows)` of a balanced Latin square (Williams 1949).
  Every item appears once per row and once per column (position), and every ordered pair of
  items is adjacent equally often, so both position and first-order carry-over effects are
  balanced across participants. For even n the square has n rows; for odd n no n-row square
  can balance carry-over, so the square is followed by its mirror image (2n rows): the first n
  participants already see each item at each position once, and 2n participants complete the
  carry-over balance.
"""

from __future__ import annotations

import hashlib
import json
import random
from typing import Any, Iterable, Sequence

ORDERS = ("fixed", "random", "latin")


def williams_first_row(n: int) -> list[int]:
    """0, 1, n−1, 2, n−2, 3, …: the first row of Williams' design (successive differences are all
    distinct mod n, which is what makes every ordered pair adjacent exactly once)."""
    row, low, high = [0], 1, n - 1
    while len(row) < n:
        row.append(low)
        low += 1
        if len(row) < n:
            row.append(high)
            high -= 1
    return row


def balanced_latin_square(n: int) -> list[list[int]]:
    """Williams' balanced Latin square over items 0..n−1: n rows for even n, 2n for odd n
    (the n-row square followed by its rows reversed); a single item has the single row [0]."""
    if n < 1:
        raise ValueError(f"a Latin square needs at least one item, got {n}")
    if n == 1:
        return [[0]]
    first = williams_first_row(n)
    rows = [[(item + shift) % n for item in first] for shift in range(n)]
    if n % 2:
        rows += [list(reversed(row)) for row in rows]
    return rows


def seed_from_parts(seed_parts: Iterable[Any]) -> int:
    """A 64-bit seed from the parts, stable across processes and platforms (SHA-256 of their JSON)."""
    text = json.dumps(list(seed_parts), separators=(",", ":"), default=str)
    return int.from_bytes(hashlib.sha256(text.encode("utf-8")).digest()[:8], "big")


def seeded_permutation(items: Iterable[Any], seed_parts: tuple) -> list:
    """The items shuffled by a generator seeded from `seed_parts`: the same parts always give the
    same order; different parts almost always a different one."""
    out = list(items)
    random.Random(seed_from_parts(seed_parts)).shuffle(out)
    return out


def order_for(order: str, n_items: int, participant_index: int, seed_parts: Sequence[Any]) -> list[int]:
    """The presentation order (indices 0..n_items−1) of one participant.

    `seed_parts` seed "random" (the caller includes the participant in them); "latin" uses the
    participant's row of the balanced Latin square; "fixed" ignores both."""
    if n_items < 0:
        raise ValueError(f"n_items must be >= 0, got {n_items}")
    if participant_index < 0:
        raise ValueError(f"participant_index must be >= 0, got {participant_index}")
    if order not in ORDERS:
        raise ValueError(f"unknown order {order!r}; known: {', '.join(ORDERS)}")
    if order == "fixed" or n_items == 0:
        return list(range(n_items))
    if order == "random":
        return seeded_permutation(range(n_items), tuple(seed_parts))
    rows = balanced_latin_square(n_items)
    return list(rows[participant_index % len(rows)])  # "latin"
