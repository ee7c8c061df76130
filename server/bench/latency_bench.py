"""`viestac bench latency`: tracker message sent → device command written on an emulated FerroVibe's pty.

The whole production path, nothing mocked: a participant tracker (in the load generator's
process; by default a tracker bridge sending to the loop's tracker UDP port, `--tracker ws` for
the browser's /ws path through the hub) → loop tick (god-object, contact gate, tilt cue) → cue
channel → the device host process (feed thread, DeviceManager, encoder) → pyserial → pty →
FerroVibe emulator (the C firmware core, in this process). The tracker switches the HIP between
in contact with the contact-angle dome (tilt cue on) and well above it (cue off) every 66-100 ms
and stamps each switching message with CLOCK_MONOTONIC.

Three end points, all on the same clock, for the first command frame that shows the switch's
new state (magnitude > 0 or == 0):
- written (`p50_ms`, `p99_ms`, `max_ms`): the host's write() of that frame to the pty returned
  (the writer thread stamps every write, `/api/devices?writes=N`);
- read (`read_*`): the emulator's thread read it off the pty master. This adds the kernel's pty
  hand-over, done by a normal-priority kworker that waits for a CPU on a busy machine (up to
  3-4 ms at 64 viewers); a USB serial adapter has no such step on the way out (it has USB's own
  frame timing);
- wire (`wire_*`): the modelled arrival of the frame's last byte on a 115200-baud line (86.8 µs
  per byte, ~0.87 ms for a SET_TILT), what a real FerroVibe would see.
Samples: a switch every 83 ms on average gives 12 per second, so by default the window lasts as
long as 1000 switches need (~92 s; `seconds_for`), and every p99 comes with its distribution-free
95 % confidence interval (`*_p99_ci95_ms`, server/bench/quantiles.py). The server keeps only its
latest 1024 device writes and 4096 applied tracker samples, so they are collected every 2 s
during the window.
"""

from __future__ import annotations

import bisect
import gc
import json
import math
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from devices.emulator import Emulator
from server.bench.load import LATENCY_SWITCH_HZ, wait_ready
from server.bench.loop_bench import _rss_summary, _tree_rss_mb, off_loop_cpu, token_option
from server.launcher import get_json, start_server, stop_server
from server.bench.quantiles import tail

SAMPLES = 1000    # by default the run lasts long enough for this many switches: a p99 from ~100 is the maximum
POLL_S = 2.0      # the server keeps the last 1024 device writes and 4096 tracker rows: collect them this often


def match_switches(switches: list[list], edges, read_at: list[tuple[int, int, bytes]]) -> list[tuple | None]:
    """For every switch [send t_us, seq, in_contact]: (read t_us, arrival t_us, frame bytes) of the
    first command edge read off the pty at or after the send that shows its state, or None if none
    did before the next switch was sent (a later one would be the next switch's, or a resend)."""
    read_of = {arrival: (read, chunk) for arrival, read, chunk in read_at}  # a command edge is stamped at its frame's arrival
    shown = sorted((*read_of[e.t_us], e.t_us, e.magnitude > 0) for e in edges
                   if e.cause == "command" and e.t_us in read_of)
    reads = [s[0] for s in shown]
    matches: list[tuple | None] = []
    for i, (t_us, _seq, on) in enumerate(switches):
        limit = switches[i + 1][0] if i + 1 < len(switches) else math.inf
        k = bisect.bisect_left(reads, t_us)
        while k < len(shown) and shown[k][0] < limit and shown[k][3] != bool(on):
            k += 1
        matches.append((shown[k][0], shown[k][2], shown[k][1]) if k < len(shown) and shown[k][0] < limit else None)
    return matches


def written_at(frame: bytes, read_us: int, writes: list[tuple[int, bytes]], window_us: int = 50_000) -> int | None:
    """When the host's write() that carried `frame` returned (t_us): the write containing those
    bytes nearest to the emulator's read of them, within `window_us` (frames carry a sequence
    number, so the same bytes recur only 256 frames later). None if no write carried them."""
    best = None
    k = bisect.bisect_left(writes, (read_us - window_us, b""))
    while k < len(writes) and writes[k][0] <= read_us + window_us:
        t_us, data = writes[k]
        if frame in data and (best is None or abs(t_us - read_us) < abs(best - read_us)):
            best = t_us
        k += 1
    return best


def _wait_connected(base: str, timeout_s: float = 10.0) -> None:
    deadline = time.monotonic() + timeout_s
    while True:
        devices = get_json(base + "/api/devices")["devices"]
        if devices and all(d["status"] == "connected" for d in devices):
            return
        if time.monotonic() > deadline:
            raise RuntimeError(f"the emulated FerroVibe did not connect: {[d['status'] for d in devices]}")
        time.sleep(0.05)


TRACKERS = ("udp", "ws")


def _collect(base: str, writes: set[tuple[int, str]], rows: dict[tuple, list]) -> tuple[dict, dict]:
    """Add the server's device writes and applied tracker rows to what was collected before (its
    logs keep only the latest); returns the device's snapshot and the feed's."""
    snapshot = get_json(base + "/api/devices?writes=1024")
    device = snapshot["devices"][0]
    writes.update((t_ns, data) for t_ns, data in device["writes"])
    for row in get_json(base + "/api/trackers?limit=4096")["rows"]:
        rows[row[0], row[1]] = row  # (client, seq)
    return device, snapshot.get("feed") or {}


def seconds_for(samples: int) -> float:
    """How long the window must be for `samples` switches (10 % spare for unmatched ones)."""
    return math.ceil(samples / LATENCY_SWITCH_HZ * 1.1)


def run_latency_bench(seconds: float | None = None, clients: int = 0, warmup_s: float = 3.0, tracker: str = "udp",
                      samples: int = SAMPLES) -> dict:
    """`seconds` None: as long as `samples` switches need (seconds_for)."""
    if samples < 1:
        raise ValueError(f"samples must be >= 1, got {samples}")
    seconds = seconds_for(samples) if seconds is None else seconds
    if not 0 < seconds <= 3600:
        raise ValueError(f"seconds must be in (0, 3600], got {seconds}")
    if clients < 0:
        raise ValueError(f"clients must be >= 0, got {clients}")
    if warmup_s < 0:
        raise ValueError(f"warmup_s must be >= 0, got {warmup_s}")
    if tracker not in TRACKERS:
        raise ValueError(f"tracker must be one of {', '.join(TRACKERS)}, got {tracker!r}")
    directory = Path(tempfile.mkdtemp(prefix="viestac-latency-"))
    emulator = Emulator("ferrovibe", link=directory / "ferrovibe", realtime=True)
    emulator.start()
    # The emulator's thread stamps the reads: a full collection in this process would delay them
    # (the server freezes its start-up heap the same way, server/app.py).
    gc.collect()
    gc.freeze()
    proc = load = None
    try:
        proc, base = start_server("contact-angle", extra=["--no-rig", "--device", f"ferrovibe@{emulator.path}"])
        _wait_connected(base)
        ws_url = base.replace("http://", "ws://") + "/ws"
        udp = ["--latency-udp", get_json(base + "/api/health")["tracker_udp"]] if tracker == "udp" else []
        load = subprocess.Popen([sys.executable, "-m", "server.bench.load", "--url", ws_url, "--viewers", str(clients),
                                 "--trackers", "0", "--latency-tracker", *udp, "--warmup", str(warmup_s),
                                 "--seconds", str(seconds), *token_option(base), *off_loop_cpu(base)],
                                stdout=subprocess.PIPE, text=True)
        wait_ready(load)  # its window starts warmup_s after its last client connected, as this one
        time.sleep(warmup_s)
        get_json(base + "/api/telemetry/reset", "POST")
        start_us = time.monotonic_ns() // 1000
        rss_samples: list[tuple[float, float]] = []  # (seconds since the reset, MB)
        seen_writes: set[tuple[int, str]] = set()
        seen_rows: dict[tuple, list] = {}
        next_poll = time.monotonic() + POLL_S
        while (now_us := time.monotonic_ns() // 1000) < start_us + seconds * 1e6:
            rss_samples.append(((now_us - start_us) / 1e6, _tree_rss_mb(proc.pid)))
            if time.monotonic() >= next_poll:
                _collect(base, seen_writes, seen_rows)
                next_poll += POLL_S
            time.sleep(0.25)
        end_us = time.monotonic_ns() // 1000
        telemetry = get_json(base + "/api/telemetry")
        # The tracker runs on for 0.2 s after the window (load.py), so the last switches arrive too.
        out, _ = load.communicate(timeout=60)
        load_result = json.loads(out.strip().splitlines()[-1])
        time.sleep(0.05)
        edges, read_at = emulator.snapshot_edges(), emulator.snapshot_read_at()
        device, feed = _collect(base, seen_writes, seen_rows)
        writes = sorted((t_ns // 1000, bytes.fromhex(data)) for t_ns, data in seen_writes)
        tracker_rows = list(seen_rows.values())
    finally:
        if load is not None and load.poll() is None:
            load.kill()
        if proc is not None:
            stop_server(proc)
        gc.unfreeze()
        emulator.stop()
        shutil.rmtree(directory, ignore_errors=True)

    switches = load_result["switches"]
    matches = match_switches(switches, edges, read_at)
    applied_us = {row[1]: row[4] // 1000 for row in tracker_rows}  # seq → tick that applied it (one tracker)
    series: dict[str, list[float]] = {k: [] for k in ("written", "read", "wire", "to_tick", "tick_to_write")}
    unmatched = unwritten = 0
    for (t_us, seq, _on), match in zip(switches, matches):
        if not start_us <= t_us <= end_us:
            continue
        if match is None:
            unmatched += 1
            continue
        read_us, arrival_us, frame = match
        write_us = written_at(frame, read_us, writes)
        if write_us is None:  # older than the device's write log: cannot happen within 1024 writes
            unwritten += 1
            continue
        series["written"].append((write_us - t_us) / 1000)
        series["read"].append((read_us - t_us) / 1000)
        series["wire"].append((arrival_us - t_us) / 1000)
        if seq in applied_us:  # split at the loop tick that applied the sample
            series["to_tick"].append((applied_us[seq] - t_us) / 1000)
            series["tick_to_write"].append((write_us - applied_us[seq]) / 1000)
    for values in series.values():
        values.sort()

    half = (("p50", 0.5), ("p99", 0.99))
    return {
        **tail(series["written"], "", "_ms"), **tail(series["read"], "read_", "_ms"),
        **tail(series["wire"], "wire_", "_ms"), **tail(series["to_tick"], "tracker_to_tick_", "_ms", half),
        **tail(series["tick_to_write"], "tick_to_write_", "_ms", half),
        "samples": len(series["written"]), "samples_wanted": samples, "unmatched": unmatched, "unwritten": unwritten, "tracker": tracker,
        "clients": clients, "frames_received_per_client_hz": load_result["frames_received_per_client_hz"]["mean"],
        "period_p99_us": telemetry["period_p99_us"], "period_max_us": telemetry["period_max_us"],
        "overruns": telemetry["overruns"], "rt": telemetry["rt"], "device_feed_rt": feed.get("rt"),
        "device_feed_delay": feed.get("delay"),
        "writer_rt": device.get("writer_rt"), "emulator_rt": emulator.rt,
        **_rss_summary(rss_samples, seconds), "seconds": seconds,
    }
