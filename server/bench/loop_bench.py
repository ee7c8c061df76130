"""`viestac bench loop`: the real server, real WebSocket clients, loop timing and memory.

Starts `viestac serve` as its own process tree (hub + loop), runs the load generator in a third
process, resets the loop's cumulative telemetry after the warm-up, and samples the resident
memory of every server process together. The numbers come from the server's own telemetry
(the loop's measured periods and tick costs), not from the client side.

The server runs through server/launcher.py, as its admin; the load generator, in another
process, gets the admin token as an argument (`token_option`).
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import time

import psutil

from server.bench.floor import run_floor
from server.bench.kernel_trace import LoopWakeTrace, summarize
from server.bench.load import wait_ready
from server.bench.quantiles import tail
from server.launcher import admin_token, get_json, start_server, stop_server


def token_option(url: str) -> list[str]:
    """The bench client processes' `--token=SECRET` for the server at `url`, as one argument: any
    secret passes so, even one starting with "-" (new_secret never draws one, other tokens may),
    which as a separate argument is read as an option and the client exits with a usage error."""
    token = admin_token(url)
    return [f"--token={token}"] if token else []


def off_loop_cpu(base: str, plan: dict | None = None) -> list[str]:
    """The load generator's `--cpus` when the server keeps its loop's CPU to itself
    (`--loop-cpu own`): the viewers stand in for remote clients, which do not run there either.
    `plan`: the server's `loop.cpus` from /api/health, if the caller has it already."""
    plan = (plan if plan is not None else get_json(base + "/api/health")["loop"].get("cpus")) or {}
    return ["--cpus", ",".join(map(str, plan["others"]))] if plan.get("own") else []


def _tree_rss_mb(pid: int) -> float:
    try:
        root = psutil.Process(pid)
        procs = [root, *root.children(recursive=True)]
    except psutil.NoSuchProcess:
        return 0.0
    total = 0
    for p in procs:
        try:
            total += p.memory_info().rss
        except psutil.NoSuchProcess:
            pass
    return total / 2**20


def _rss_summary(samples: list[tuple[float, float]], seconds: float) -> dict:
    """Peak RSS, and start/end/growth from the medians of the first and last window (10 s, or a
    quarter of a short run) so one sample (a transient allocation) does not decide the growth."""
    if not samples:
        return {"rss_mb": None, "rss_start_mb": None, "rss_end_mb": None, "rss_growth_mb": None}
    window = min(10.0, seconds / 4)
    first = [mb for t, mb in samples if t <= window] or [samples[0][1]]
    last = [mb for t, mb in samples if t >= samples[-1][0] - window] or [samples[-1][1]]
    start, end = statistics.median(first), statistics.median(last)
    return {"rss_mb": round(max(mb for _, mb in samples), 1), "rss_start_mb": round(start, 1),
            "rss_end_mb": round(end, 1), "rss_growth_mb": round(end - start, 1)}


def run_loop_bench(seconds: float = 10.0, viewers: int = 8, trackers: int = 2, warmup_s: float = 3.0,
                   scenario: str = "contact-angle", kernel_trace: bool = False, loop_cpu: str = "auto",
                   floor_s: float = 3.0) -> dict:
    """Loop timing and memory of the real server under load. `kernel_trace` also records the
    loop's timed wake-ups with the kernel's tracer (root, tracefs) and says what made late ones
    late (server/bench/kernel_trace.py). First, for `floor_s` seconds a pattern (0: not at all),
    the machine's floor under a tick in the same CPU plan (server/bench/floor.py): the baseline of
    the same run that the tick cost is read against."""
    if seconds <= 0:
        raise ValueError(f"seconds must be > 0, got {seconds}")
    if viewers < 0 or trackers < 0:
        raise ValueError(f"viewers and trackers must be >= 0, got {viewers} and {trackers}")
    if warmup_s < 0:
        raise ValueError(f"warmup_s must be >= 0, got {warmup_s}")
    if floor_s < 0:
        raise ValueError(f"floor_s must be >= 0, got {floor_s}")
    if kernel_trace:
        LoopWakeTrace.check()  # before anything starts: a clear error, nothing to clean up
    floor = run_floor(floor_s, loop_cpu) if floor_s else {}  # before the server: the machine alone
    proc, base = start_server(scenario, ["--loop-cpu", loop_cpu])
    wake_trace = None
    try:
        ws_url = base.replace("http://", "ws://") + "/ws"
        cpus = get_json(base + "/api/health")["loop"]["cpus"]
        load = subprocess.Popen([sys.executable, "-m", "server.bench.load", "--url", ws_url, "--viewers", str(viewers),
                                 "--trackers", str(trackers), "--warmup", str(warmup_s), "--seconds", str(seconds),
                                 *token_option(base), *off_loop_cpu(base, cpus)],
                                stdout=subprocess.PIPE, text=True)
        wait_ready(load)  # its window starts warmup_s after its last client connected, as this one
        time.sleep(warmup_s)
        if kernel_trace:
            buffer_kb = int(min(256 * 1024, 8192 + 400 * seconds))  # the whole window up to ~10 min
            wake_trace = LoopWakeTrace(get_json(base + "/api/health")["loop"]["pid"], buffer_kb=buffer_kb)
            wake_trace.start()
        get_json(base + "/api/telemetry/reset", "POST")
        start = time.monotonic()
        end = start + seconds
        rss_samples: list[tuple[float, float]] = []  # (seconds since the reset, MB)
        while time.monotonic() < end:
            rss_samples.append((time.monotonic() - start, _tree_rss_mb(proc.pid)))
            time.sleep(0.25)
        telemetry = get_json(base + "/api/telemetry")
        wakeups = wake_trace.stop() if wake_trace is not None else None
        tracker_rows = get_json(base + "/api/trackers?limit=4096")["rows"]
        out, _ = load.communicate(timeout=60)
        load_result = json.loads(out.strip().splitlines()[-1])
    finally:
        try:
            if wake_trace is not None and wake_trace.instance.exists():
                wake_trace.stop()  # an error on the way: still remove the trace instance
        finally:
            stop_server(proc)
    # The bench's trackers stamp `t` with CLOCK_MONOTONIC in ms (same machine, same clock), so
    # applied - t is the whole path: WebSocket send, hub read and validation, mailbox, next tick.
    send_to_tick = sorted((row[4] - row[2] * 1e6) / 1e6 for row in tracker_rows)
    hub_to_tick = sorted((row[4] - row[3]) / 1e6 for row in tracker_rows)

    rss = _rss_summary(rss_samples, seconds)
    return {
        "period_p50_us": telemetry["period_p50_us"], "period_p99_us": telemetry["period_p99_us"],
        "period_p999_us": telemetry["period_p999_us"], "period_max_us": telemetry["period_max_us"],
        "overruns": telemetry["overruns"], "ticks": telemetry["ticks"],
        "tick_cost_p50_us": telemetry["tick_cost_p50_us"], "tick_cost_p99_us": telemetry["tick_cost_p99_us"],
        "tick_cost_max_us": telemetry["tick_cost_max_us"],
        # the ticks that published a state record (every cue change and the 60 Hz frames) and the others
        **{k: telemetry[k] for k in ("published_ticks", "tick_cost_published_p50_us", "tick_cost_published_p99_us",
                                     "tick_cost_quiet_p50_us", "tick_cost_quiet_p99_us")},
        "clients": viewers, "trackers": trackers,
        "frames_received_per_client_hz": load_result["frames_received_per_client_hz"]["mean"],
        "frames_received_per_client_hz_min": load_result["frames_received_per_client_hz"]["min"],
        "tracker_messages": load_result["tracker_messages"],
        **tail(send_to_tick, "tracker_to_tick_", "_ms", (("p50", 0.5), ("p99", 0.99))),
        **tail(hub_to_tick, "hub_to_tick_", "_ms", (("p99", 0.99),)), "tracker_samples": len(send_to_tick),
        **rss, "rt": telemetry["rt"], "loop_cpu": cpus, "seconds": seconds, "resyncs": telemetry["resyncs"],
        **({"kernel_trace": {**summarize(wakeups), "lost_events": wake_trace.lost_events}}
           if wakeups is not None else {}),
        **floor,
    }
