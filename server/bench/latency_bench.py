"""`viestac bench latency`: tracker message sent → device command written on an emulated FerroVibe's pty.

The whole production path, nothing mocked: a participant tracker (WebSocket, in the load
generator's process) → hub → loop tick (god-object, contact gate, tilt cue) → state record to
the hub → DeviceManager → writer thread → pyserial → pty → FerroVibe emulator (the C firmware
core, in this process). The tracker switches the HIP between in contact with the contact-angle
dome (tilt cue on) and well above it (cue off) every 66-100 ms and stamps each switching message
with CLOCK_MONOTONIC; the emulator stamps every frame it reads off the pty with the same clock.

Latency of a switch = from its send to when the emulator read the first frame that showed the new
state (magnitude > 0 or == 0) off the pty, i.e. when the host's write had reached the pty. The
emulator's timeline itself stamps frames later, at the modelled arrival of their last byte on a
115200-baud wire (86.8 µs per byte, ~0.87 ms for a SET_TILT): reported as `wire_*`.
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
from server.bench.loop_bench import _rss_summary, _tree_rss_mb, get_json, percentile, start_server, stop_server


def match_switches(switches: list[list], edges, read_at: list[tuple[int, int]]) -> list[tuple | None]:
    """For every switch [send t_us, seq, in_contact]: (read t_us, arrival t_us) of the first command
    edge read off the pty at or after the send that shows the switch's state, or None if none did
    before the next switch was sent (a later one would be the next switch's, or a resend)."""
    read_of = dict(read_at)  # arrival t_us → read t_us; a command edge is stamped at its frame's arrival
    shown = sorted((read_of[e.t_us], e.t_us, e.magnitude > 0) for e in edges
                   if e.cause == "command" and e.t_us in read_of)
    reads = [s[0] for s in shown]
    matches: list[tuple | None] = []
    for i, (t_us, _seq, on) in enumerate(switches):
        limit = switches[i + 1][0] if i + 1 < len(switches) else math.inf
        k = bisect.bisect_left(reads, t_us)
        while k < len(shown) and shown[k][0] < limit and shown[k][2] != bool(on):
            k += 1
        matches.append(shown[k][:2] if k < len(shown) and shown[k][0] < limit else None)
    return matches


def _wait_connected(base: str, timeout_s: float = 10.0) -> None:
    deadline = time.monotonic() + timeout_s
    while True:
        devices = get_json(base + "/api/devices")["devices"]
        if devices and all(d["status"] == "connected" for d in devices):
            return
        if time.monotonic() > deadline:
            raise RuntimeError(f"the emulated FerroVibe did not connect: {[d['status'] for d in devices]}")
        time.sleep(0.05)


def run_latency_bench(seconds: float = 10.0, clients: int = 0, warmup_s: float = 3.0) -> dict:
    if not 0 < seconds <= 3600:
        raise ValueError(f"seconds must be in (0, 3600], got {seconds}")
    if clients < 0:
        raise ValueError(f"clients must be >= 0, got {clients}")
    if warmup_s < 0:
        raise ValueError(f"warmup_s must be >= 0, got {warmup_s}")
    directory = Path(tempfile.mkdtemp(prefix="viestac-latency-"))
    emulator = Emulator("ferrovibe", link=directory / "ferrovibe")
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
        load = subprocess.Popen([sys.executable, "-m", "server.bench.load", "--url", ws_url, "--viewers", str(clients),
                                 "--trackers", "0", "--latency-tracker", "--warmup", str(warmup_s),
                                 "--seconds", str(seconds)], stdout=subprocess.PIPE, text=True)
        time.sleep(warmup_s)
        get_json(base + "/api/telemetry/reset", "POST")
        start_us = time.monotonic_ns() // 1000
        rss_samples: list[tuple[float, float]] = []  # (seconds since the reset, MB)
        while (now_us := time.monotonic_ns() // 1000) < start_us + seconds * 1e6:
            rss_samples.append(((now_us - start_us) / 1e6, _tree_rss_mb(proc.pid)))
            time.sleep(0.25)
        end_us = time.monotonic_ns() // 1000
        telemetry = get_json(base + "/api/telemetry")
        tracker_rows = get_json(base + "/api/trackers?limit=4096")["rows"]
        # The tracker runs on for 0.2 s after the window (load.py), so the last switches arrive too.
        out, _ = load.communicate(timeout=60)
        load_result = json.loads(out.strip().splitlines()[-1])
        time.sleep(0.05)
        edges, read_at = emulator.snapshot_edges(), emulator.snapshot_read_at()
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
    to_pty, to_wire, to_tick, tick_to_pty = [], [], [], []
    unmatched = 0
    for (t_us, seq, _on), match in zip(switches, matches):
        if not start_us <= t_us <= end_us:
            continue
        if match is None:
            unmatched += 1
            continue
        read_us, arrival_us = match
        to_pty.append((read_us - t_us) / 1000)
        to_wire.append((arrival_us - t_us) / 1000)
        if seq in applied_us:  # split: tracker → loop tick, and tick → pty (hub, writer thread, pyserial)
            to_tick.append((applied_us[seq] - t_us) / 1000)
            tick_to_pty.append((read_us - applied_us[seq]) / 1000)
    for values in (to_pty, to_wire, to_tick, tick_to_pty):
        values.sort()
    return {
        "p50_ms": percentile(to_pty, 0.5), "p99_ms": percentile(to_pty, 0.99), "max_ms": percentile(to_pty, 1.0),
        "wire_p50_ms": percentile(to_wire, 0.5), "wire_p99_ms": percentile(to_wire, 0.99),
        "wire_max_ms": percentile(to_wire, 1.0),
        "tracker_to_tick_p50_ms": percentile(to_tick, 0.5), "tracker_to_tick_p99_ms": percentile(to_tick, 0.99),
        "tick_to_pty_p50_ms": percentile(tick_to_pty, 0.5), "tick_to_pty_p99_ms": percentile(tick_to_pty, 0.99),
        "samples": len(to_pty), "unmatched": unmatched, "clients": clients,
        "frames_received_per_client_hz": load_result["frames_received_per_client_hz"]["mean"],
        "period_p99_us": telemetry["period_p99_us"], "period_max_us": telemetry["period_max_us"],
        "overruns": telemetry["overruns"], "rt": telemetry["rt"],
        **_rss_summary(rss_samples, seconds), "seconds": seconds,
    }
