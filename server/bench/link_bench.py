"""`viestac bench link`: a cue that changes every tick, through the real device byte path.

A FerroVibe emulator on a pty (the C firmware core, 115200-baud wire time modelled) and a
DeviceManager opening it with pyserial, in this process. For `seconds`, a new tilt direction is
submitted every 1/rate_hz s (directions grow, so the emulator's timeline shows which value
arrived when). Reported: the share of the link the host used (86.8 µs per byte), over the run
and in the worst 1 s window, and for every submitted value the time until the device showed it
or a newer one (docs/device-protocol.md §5: the newest value must arrive within 20 ms).
"""

from __future__ import annotations

import bisect
import gc
import tempfile
import time
from pathlib import Path

from server.core.cues import Tilt
from devices.emulator import BYTE_TIME_US, Emulator
from devices.manager import DeviceConfig, DeviceManager
from devices.ports import PortSpec
from devices.profiles import profile_by_model
from server.bench.quantiles import tail

LINK_BYTES_PER_S = 1e6 / BYTE_TIME_US  # 11,520 B/s at 115200 8N1


def run_link_bench(seconds: float = 10.0, rate_hz: float = 1000.0, share: float = 0.5) -> dict:
    if not 0 < seconds <= 300:
        raise ValueError("seconds must be in (0, 300]")
    directory = Path(tempfile.mkdtemp(prefix="viestac-link-"))
    emulator = Emulator("ferrovibe", link=directory / "ferrovibe")
    emulator.start()
    config = DeviceConfig("ferrovibe", profile_by_model("ferrovibe"), PortSpec.parse(str(directory / "ferrovibe")),
                          link_share=share)
    manager = DeviceManager([config], reopen_interval_s=0.1)
    manager.start()
    gc.collect()
    gc.freeze()  # as the server does after start-up (server/app.py)
    try:
        deadline = time.monotonic() + 5
        while manager.status()["ferrovibe"] != "connected":
            if time.monotonic() > deadline:
                raise RuntimeError("the emulated FerroVibe did not connect")
            time.sleep(0.01)
        time.sleep(0.1)
        sent: list[tuple[int, int]] = []  # (t_us, direction_cdeg)
        start_us = time.monotonic_ns() // 1000
        next_tick = time.monotonic()
        i = 0
        while time.monotonic_ns() // 1000 - start_us < seconds * 1e6:
            cdeg = i % 36_000
            sent.append((time.monotonic_ns() // 1000, cdeg))
            manager.submit((Tilt(cdeg / 100, 100),))
            i += 1
            next_tick += 1 / rate_hz
            time.sleep(max(0.0, next_tick - time.monotonic()))
        time.sleep(0.1)
        edges = emulator.snapshot_edges()
        received = emulator.snapshot_received()
    finally:
        gc.unfreeze()
        manager.stop()
        emulator.stop()
    end_us = sent[-1][0]
    in_run = [(t, n) for t, n in received if start_us <= t <= end_us + 100_000]
    windows: dict[int, int] = {}
    for t, n in in_run:
        windows[(t - start_us) // 1_000_000] = windows.get((t - start_us) // 1_000_000, 0) + n
    shown = [(e.t_us, e.direction_cdeg) for e in edges if e.cause == "command" and e.t_us >= start_us
             and e.magnitude == 100]
    shown_cdeg = [c for _, c in shown]
    latencies = []
    missing = 0
    wrap = len(sent) > 36_000  # directions repeat after 360°: only the first lap is unambiguous
    for t_sent, cdeg in (sent[:36_000] if wrap else sent):
        k = bisect.bisect_left(shown_cdeg, cdeg)
        if k == len(shown):
            missing += 1
        else:
            latencies.append(shown[k][0] - t_sent)
    latencies_ms = sorted(v / 1000 for v in latencies)

    return {"seconds": round((end_us - start_us) / 1e6, 3), "values_submitted": len(sent),
            "frames_shown": len(shown), "in_order": shown_cdeg == sorted(shown_cdeg), "values_missing": missing,
            "link_share": round(sum(n for _, n in in_run) / ((end_us - start_us) / 1e6) / LINK_BYTES_PER_S, 4),
            "link_share_worst_1s": round(max(windows.values(), default=0) / LINK_BYTES_PER_S, 4),
            **tail(latencies_ms, "latency_", "_ms")}
