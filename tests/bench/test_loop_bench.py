"""`viestac bench loop`: the memory summary, and the shape of a short live run. Timing and memory
goals are reported by the bench (docs/performance.md), never asserted here."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest

from server.bench.kernel_trace import LoopWakeTrace
from server import launcher
from server.bench import loop_bench
from server.bench.loop_bench import _rss_summary, run_loop_bench



def test_rss_growth_compares_medians_of_the_first_and_last_window_so_one_spike_does_not_count():
    samples = [(i * 0.25, 80.0) for i in range(240)]  # 60 s at 80 MB ...
    samples[5] = (1.25, 120.0)                          # ... one transient allocation early on
    samples += [(60 + i * 0.25, 81.0) for i in range(40)]  # then 10 s at 81 MB
    rss = _rss_summary(samples, 70.0)
    assert rss == {"rss_mb": 120.0, "rss_start_mb": 80.0, "rss_end_mb": 81.0, "rss_growth_mb": 1.0}


def test_a_short_run_uses_a_quarter_of_it_at_each_end():
    samples = [(i * 0.25, 50.0 + i) for i in range(8)]  # 2 s: 50 .. 57 MB
    rss = _rss_summary(samples, 2.0)
    assert (rss["rss_start_mb"], rss["rss_end_mb"], rss["rss_mb"]) == (51.0, 56.0, 57.0)
    assert _rss_summary([], 2.0)["rss_growth_mb"] is None


@pytest.mark.parametrize("kwargs", [{"seconds": 0}, {"viewers": -1}, {"trackers": -2}, {"warmup_s": -1},
                                    {"floor_s": -1}])
def test_bad_arguments_are_refused_before_anything_starts(kwargs):
    with pytest.raises(ValueError):
        run_loop_bench(**kwargs)


@pytest.mark.slow
def test_a_short_live_run_reports_loop_timing_and_memory():
    traced = LoopWakeTrace.usable()  # where the kernel's tracer can be used, check its account too
    result = run_loop_bench(seconds=2, viewers=2, warmup_s=1, kernel_trace=traced, floor_s=1)
    print(f"\n{result}")
    for key in ("period_p50_us", "period_p99_us", "tick_cost_p50_us", "frames_received_per_client_hz",
                "tracker_to_tick_p50_ms", "rss_mb", "rss_start_mb", "rss_end_mb"):
        assert isinstance(result[key], (int, float)) and math.isfinite(result[key]) and result[key] > 0, key
    assert result["period_p50_us"] <= result["period_p99_us"] <= result["period_max_us"]
    assert result["ticks"] > 1000 and result["overruns"] >= 0 and result["clients"] == 2
    # the ticks that published a state record (60 Hz frames and every cue change) and the others
    assert 100 <= result["published_ticks"] < result["ticks"] / 2
    assert result["tick_cost_quiet_p50_us"] <= result["tick_cost_published_p50_us"], "publishing is more work"
    assert result["tick_cost_published_p50_us"] <= result["tick_cost_published_p99_us"]
    assert result["rss_start_mb"] <= result["rss_mb"] and result["rss_end_mb"] <= result["rss_mb"]
    assert math.isfinite(result["rss_growth_mb"])
    # the machine's floor, measured first with the same CPU plan (server/bench/floor.py)
    assert result["floor_ticks"] == 1000 and result["floor_cpus"] == result["loop_cpu"]
    assert result["floor_records_received"] == [result["floor_sending_ticks"]] * 2
    if traced:  # one traced wake-up per tick of the window, give or take the moments around it
        kernel = result["kernel_trace"]
        assert abs(kernel["traced_wakeups"] - result["ticks"]) < 0.1 * result["ticks"]
        assert 0 <= kernel["timer_late_p50_us"] <= kernel["timer_late_p99_us"] <= kernel["timer_late_max_us"]
        assert kernel["late_wakeups"] == kernel["late_by_timer_interrupt"] + kernel["late_by_scheduling"]
    else:
        assert "kernel_trace" not in result


def test_a_secret_that_starts_with_a_dash_reaches_the_load_generator_as_its_token(monkeypatch):
    monkeypatch.setitem(launcher.ADMIN_TOKENS, "http://127.0.0.1:9", "-Ab_c")  # token_urlsafe does this 1 in 64
    option = loop_bench.token_option("ws://127.0.0.1:9/ws")
    assert option == ["--token=-Ab_c"] and loop_bench.token_option("http://127.0.0.1:10") == []
    proc = subprocess.run([sys.executable, "-m", "server.bench.load", "--url", "ws://127.0.0.1:9/ws", "--viewers", "0",
                           "--trackers", "0", "--seconds", "0.1", "--warmup", "0", *option],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr  # a separate "-Ab_c" argument was a usage error (exit 2)
    ready, result = proc.stdout.splitlines()  # `ready` once every client (none here) is connected, then the result
    assert ready == "ready" and json.loads(result)["viewers"] == 0
