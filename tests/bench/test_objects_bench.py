"""`viestac bench objects`: the scenes, the path and the JSON/chart it writes (no timing goals here:
those are read from the bench's output, docs/performance.md)."""

from __future__ import annotations

import json
import math

import pytest

from server.bench.objects import QUICK_COUNTS, cluttered_scene, methods, path, run_objects_bench
from server.core.haptics.compiled import COMPILED


@pytest.mark.parametrize("n", [1, 50])
def test_the_cluttered_table_has_n_objects_away_from_the_touched_one(n):
    bodies = cluttered_scene(n)
    assert len(bodies) == n + 1 and bodies[0].id == "ground" and bodies[1].id == "b0"
    assert len({b.id for b in bodies}) == n + 1
    assert all(math.hypot(*b.pose.pos[:2]) >= 0.3 for b in bodies[2:])
    assert cluttered_scene(n) == bodies  # seeded: the same table every run


@pytest.mark.slow
def test_the_quick_bench_writes_every_count_and_method_with_free_and_contact_ticks(tmp_path):
    summary = run_objects_bench(tmp_path, quick=True)
    data = json.loads((tmp_path / "objects.json").read_text())
    assert (tmp_path / "objects.png").stat().st_size > 10_000 and summary["json"] == str(tmp_path / "objects.json")
    assert [r["objects"] for r in data["rows"]] == list(QUICK_COUNTS) and data["compiled"] == COMPILED
    for row in data["rows"]:
        assert set(row["methods"]) == set(methods())
        for m in row["methods"].values():
            for phase in ("free", "contact"):  # the path sweeps free space and strokes b0
                s = m[phase]
                assert s["ticks"] > 0 and 0.0 < s["p50_us"] <= s["p99_us"] and math.isfinite(s["p99_us"])
    assert len(path()) > 4 * len(path(reduced=True)) - 4


def test_the_tools_axis_puts_every_fingertip_in_contact_and_moves_them():
    from server.bench.tools_axis import FINGERTIPS, fingertip, sample, time_tools

    assert len(set(FINGERTIPS)) == 10 and sample(3, 5, 1).points.keys() == set(FINGERTIPS[1:3])
    assert fingertip(0, 0) != fingertip(0, 100) and fingertip(0, 0) != fingertip(1, 0)
    row = time_tools(3, 1, 50)
    assert row["all_in_contact"] and row["states_per_tick"] == 1.0  # the primary's cue changes every tick
    for part in ("tick", "god_object"):
        assert 0.0 < row[part]["p50_us"] <= row[part]["p99_us"]


@pytest.mark.slow
def test_the_quick_bench_charts_the_tools_axis(tmp_path):
    from server.bench.tools_axis import QUICK_TOOL_COUNTS

    run_objects_bench(tmp_path, quick=True)
    data = json.loads((tmp_path / "objects.json").read_text())
    assert [r["tools"] for r in data["tools"]] == list(QUICK_TOOL_COUNTS)
    assert (tmp_path / "tools.png").stat().st_size > 10_000
