"""`viestac bench floor`: the machine's floor under a tick, measured in a child process with the
loop's CPU plan and priority. The numbers are reported, never asserted (docs/performance.md);
what is asserted is that every tick was measured and every record reached its receiver."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import pytest

from server.bench.floor import run_floor
from server.cpu_plan import plan_cpus


@pytest.mark.parametrize("kwargs", [{"seconds": 0}, {"seconds": -1}, {"publish_every": 0}, {"loop_cpu": "fast"}])
def test_bad_arguments_are_refused_before_anything_starts(kwargs):
    with pytest.raises(ValueError):
        run_floor(**kwargs)


def test_the_child_refuses_bad_arguments_with_a_usage_error():
    proc = subprocess.run([sys.executable, "-m", "server.bench.floor", "--seconds", "0"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and "seconds must be > 0" in proc.stderr and proc.stdout == ""


@pytest.mark.parametrize("mode", ["shared", "own"])
def test_a_short_run_measures_every_tick_and_every_record_arrives(mode):
    result = run_floor(seconds=1.2, loop_cpu=mode, publish_every=4)
    print(f"\n{mode}: {result}")
    assert result["floor_ticks"] == 1200 and result["floor_publish_every"] == 4
    assert result["floor_sending_ticks"] == 300  # ticks 0, 4, 8, ...
    assert result["floor_records_received"] == [300, 300]  # each receiver got one record per sending tick
    for pattern in ("idle", "sends"):
        p50, p99, top = (result[f"floor_{pattern}_{p}_us"] for p in ("p50", "p99", "max"))
        assert all(math.isfinite(v) and v > 0 for v in (p50, p99, top)) and p50 <= p99 <= top, pattern
        low, high = result[f"floor_{pattern}_p99_ci95_us"]
        assert low <= p99 and (high is None or p99 <= high), pattern
    assert result["floor_sending_tick_p50_us"] <= result["floor_sending_tick_p99_us"]
    assert result["floor_cpus"] == plan_cpus(os.sched_getaffinity(0), mode).to_dict()


def test_the_command_line_prints_one_json_object():
    proc = subprocess.run([sys.executable, "-m", "server.cli", "bench", "floor", "--seconds", "1",
                           "--publish-every", "10", "--json"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    assert result["floor_ticks"] == 1000 and result["floor_records_received"] == [100, 100]
