"""Orders: Williams squares have their defining properties; seeded permutations are reproducible."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest

from server.experiment.order import (balanced_latin_square, order_for, seed_from_parts, seeded_permutation,
                                     williams_first_row)

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("n", range(2, 9))
def test_balanced_latin_square_properties(n):
    rows = balanced_latin_square(n)
    assert len(rows) == (n if n % 2 == 0 else 2 * n)
    for row in rows:  # each condition once per row
        assert sorted(row) == list(range(n))
    per_column = len(rows) // n
    for column in range(n):  # each condition equally often in each position
        assert Counter(row[column] for row in rows) == {c: per_column for c in range(n)}
    adjacent = Counter((row[i], row[i + 1]) for row in rows for i in range(n - 1))
    expected = {(a, b): per_column for a in range(n) for b in range(n) if a != b}
    assert adjacent == expected  # each ordered pair adjacent equally often (once, or twice for odd n)


@pytest.mark.parametrize("n", [3, 5, 7])
def test_odd_square_is_position_balanced_after_its_first_n_rows(n):
    # the first n participants already see every condition at every position once
    rows = balanced_latin_square(n)[:n]
    for column in range(n):
        assert sorted(row[column] for row in rows) == list(range(n))


def test_small_squares_are_the_textbook_ones():
    assert balanced_latin_square(1) == [[0]]
    assert balanced_latin_square(2) == [[0, 1], [1, 0]]
    assert williams_first_row(4) == [0, 1, 3, 2]
    assert balanced_latin_square(4) == [[0, 1, 3, 2], [1, 2, 0, 3], [2, 3, 1, 0], [3, 0, 2, 1]]
    assert balanced_latin_square(3)[3:] == [[2, 1, 0], [0, 2, 1], [1, 0, 2]]  # the mirror half


def test_empty_square_is_an_error():
    with pytest.raises(ValueError):
        balanced_latin_square(0)


def test_seeded_permutation_is_reproducible_and_varies_with_the_parts():
    items = list(range(10))
    first = seeded_permutation(items, (2021, 0, "task", 0))
    assert first == seeded_permutation(items, (2021, 0, "task", 0))
    assert sorted(first) == items and items == list(range(10))  # the input is not shuffled in place
    orders = {tuple(seeded_permutation(items, (2021, p, "task", 0))) for p in range(50)}
    assert len(orders) >= 48  # 10! orders: different participants almost always differ


def test_seed_parts_are_typed():
    assert seed_from_parts((1,)) != seed_from_parts(("1",))
    assert seed_from_parts((1, 23)) != seed_from_parts((12, 3))
    assert 0 <= seed_from_parts(("x",)) < 2**64


def test_seeded_permutation_does_not_depend_on_the_process_hash_seed():
    code = ("import json; from server.experiment.order import seeded_permutation; "
            "print(json.dumps(seeded_permutation(['a', 'b', 'c', 'd', 'e', 'f'], (7, 3, 'pairs', 1))))")
    outs = []
    for hash_seed in ("1", "2"):
        env = {**os.environ, "PYTHONHASHSEED": hash_seed}
        done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True,
                              check=True)
        outs.append(json.loads(done.stdout))
    assert outs[0] == outs[1] == seeded_permutation(['a', 'b', 'c', 'd', 'e', 'f'], (7, 3, 'pairs', 1))


def test_order_for():
    assert order_for("fixed", 4, 3, ()) == [0, 1, 2, 3]
    assert order_for("random", 6, 0, (1, 0, "t", 0)) == seeded_permutation(range(6), (1, 0, "t", 0))
    assert order_for("latin", 4, 5, ()) == balanced_latin_square(4)[1]  # participant 5 → row 5 % 4
    assert order_for("latin", 2, 12, ()) == [0, 1] and order_for("latin", 2, 11, ()) == [1, 0]
    assert order_for("random", 0, 0, ()) == []


@pytest.mark.parametrize("args", [("sideways", 3, 0, ()), ("fixed", -1, 0, ()), ("latin", 3, -1, ())])
def test_order_for_rejects_bad_arguments(args):
    with pytest.raises(ValueError):
        order_for(*args)
