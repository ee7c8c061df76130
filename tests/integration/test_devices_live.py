"""Devices with the real server: a FerroVibe emulator owned by the test, unplugged and replugged
while a tracker sweeps the dome. The server sees an ordinary serial port (`--device`)."""

from __future__ import annotations

import asyncio
import math
import threading
import time

import pytest
from scipy.stats import poisson

from devices.emulator import Emulator
from tests.live_server import get_json, start_server, stop_server
from tests.integration.test_server_ws import Client, _on_dome


@pytest.fixture
def server_with_emulated_ferrovibe(tmp_path):
    emulator = Emulator("ferrovibe", link=tmp_path / "ferrovibe")
    emulator.start()
    proc, base = start_server("contact-angle", ["--device", f"ferrovibe@{tmp_path / 'ferrovibe'}"])
    try:
        yield emulator, base
    finally:
        stop_server(proc)
        emulator.stop()


def status(base: str) -> str:
    return get_json(base + "/api/devices")["devices"][0]["status"]


def wait_status(base: str, wanted: str, timeout_s: float) -> float:
    start = time.monotonic()
    while status(base) != wanted:
        if time.monotonic() - start > timeout_s:
            raise AssertionError(f"device not {wanted} within {timeout_s} s (is {status(base)})")
        time.sleep(0.02)
    return time.monotonic() - start


def sweep_dome(base: str, stop: threading.Event) -> None:
    """A 120 Hz tracker sweeping the dome: the tilt cue changes with every sample."""
    async def go():
        client = await Client.connect(base.replace("http://", "ws://") + "/ws")
        await client.recv_type("scene")
        seq = 0
        while not stop.is_set():
            angle = 80 * math.sin(2 * math.pi * 0.5 * time.monotonic())
            await client.send({"type": "tracker", "seq": seq, "t": time.monotonic() * 1e3, "pos": _on_dome(angle)})
            seq += 1
            await asyncio.sleep(1 / 120)
        await client.close()
    asyncio.run(go())


def test_unplug_and_replug_under_load_leave_the_loop_alone(server_with_emulated_ferrovibe):
    emulator, base = server_with_emulated_ferrovibe
    wait_status(base, "connected", 5.0)
    stop = threading.Event()
    sweeper = threading.Thread(target=sweep_dome, args=(base, stop), daemon=True)
    sweeper.start()
    try:
        time.sleep(1.0)
        get_json(base + "/api/telemetry/reset", "POST")
        time.sleep(3.0)
        before = get_json(base + "/api/telemetry")
        frames_before = len(emulator.snapshot_edges())
        assert frames_before > 50, "the sweeping tilt reached the emulator"

        get_json(base + "/api/telemetry/reset", "POST")
        emulator.unplug()
        # an upper bound for a hang, not the detection time (that is `viestac bench faults`' figure,
        # judged against docs/reliability.md): a loaded machine took longer than 1 s here
        took = wait_status(base, "disconnected", 5.0)
        time.sleep(1.0)
        emulator.replug()
        wait_status(base, "connected", 3.0)
        time.sleep(1.0)
        during = get_json(base + "/api/telemetry")
        edges_after = [e for e in emulator.snapshot_edges() if e.cause == "command"]
    finally:
        stop.set()
        sweeper.join(5)
    print(f"\ndisconnected after {took * 1000:.0f} ms; overruns {before['overruns']} in {before['ticks']} ticks "
          f"before, {during['overruns']} in {during['ticks']} ticks across unplug+replug; period p99 "
          f"{before['period_p99_us']} / {during['period_p99_us']} us")
    assert during["ticks"] > 1800, "the loop kept ticking"
    # Overruns do not rise. On a VM they come at random (late timer interrupts, docs/performance.md
    # "Overruns on this machine"), so "the baseline rate plus one" failed about one run in seven by
    # chance; allow what twice the baseline rate (at least 1 per baseline window) gives in 999 of
    # 1000 windows: the rate is not stationary when the whole suite shares the machine (a fresh-
    # clone run saw 5 in 3003 ticks, then 12 in 2042; period p99 1.03 ms in both). A stall
    # from the unplug costs tens of overruns and still fails.
    rate = 2 * max(before["overruns"], 1) / max(1, before["ticks"])
    allowed = poisson.ppf(0.999, rate * during["ticks"])
    assert during["overruns"] <= allowed
    snap = get_json(base + "/api/devices")["devices"][0]
    assert snap["disconnects"] == 1 and snap["connects"] == 2 and snap["status"] == "connected"
    assert any(e["event"] == "StatusChanged" and e["new"] == "disconnected" for e in snap["events"])
    assert len(edges_after) > frames_before, "the new pty got the sweeping tilt again after the replug"
    health = get_json(base + "/api/health")
    assert health["loop"]["alive"] and health["loop"]["restarts"] == 0
