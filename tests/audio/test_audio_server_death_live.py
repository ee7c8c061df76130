"""`viestac serve --rig audio`: the audio server dying mid-trial makes health degraded (the texture
scenario needs the audio tactor), and the device is back when the server is; the trial goes on
and nothing it recorded is lost. A module of its own, so no other server runs beside it."""

from __future__ import annotations

import asyncio
import os
import shutil
import signal
import sqlite3
import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from devices.rig import emulator_command
from tests.audio.test_audio_live import audio_device, audio_rows, wait_until
from tests.integration.test_experiment_live import Api
from tests.integration.test_scenarios_live import Server, drive, now_us
from tests.live_server import start_server, stop_server

pytestmark = pytest.mark.skipif(shutil.which("jackd") is None, reason="jackd is not installed (Debian: jackd2)")

STUDY = """
id = "audio-death"
title = "An audio tactor's server dies mid-trial"
seed = 1
participants = 1

[[tasks]]
id = "feel"
scenario = "texture"
conditions = [{ period_us = 3000.0 }]
questions = [{ id = "rough", kind = "number", text = "How rough was it?", low = 0, high = 10 }]
"""
ON_THE_PLANE = [(0.0, 0.2, 0.5), (0.0, 0.2, 0.03)]


def test_the_audio_server_dying_mid_trial_degrades_health_until_it_is_back_and_loses_nothing(tmp_path):
    pytest.importorskip("jack")
    pytest.importorskip("sounddevice")
    studies, data = tmp_path / "studies", tmp_path / "data"
    studies.mkdir()
    (studies / "audio-death.toml").write_text(STUDY)
    proc, base = start_server("texture", extra=["--rig", "audio", "--data-dir", str(data), "--record-every", "5",
                                                "--studies", str(studies)], timeout_s=120.0)
    emulator = None
    api = Api(base)
    try:
        server = Server(base)
        wait_until(lambda: audio_device(server)["status"] == "connected", 60.0, "the audio tactor")
        wait_until(lambda: server.get("/api/health")["status"] == "ok", 30.0, "health ok")
        session = api.ok("POST", "/api/sessions", {"study": "audio-death", "participant": "P1", "experimenter": "a"})
        api.token = session["token"]
        sid = session["id"]
        (seq,) = [t["seq"] for t in session["trials"] if t["kind"] == "main"]
        api.ok("POST", f"/api/sessions/{sid}/trials/{seq}/start")
        info = server.get("/api/devices")["simulated_rig"]["emulators"]["audio"]
        with ThreadPoolExecutor(1) as pool:  # the participant on the moving texture meanwhile
            t0 = now_us()
            touching = pool.submit(asyncio.run, drive(server.ws, ON_THE_PLANE, hold_s=2.0))
            audio_rows(server, t0, lambda rs: any(r["gate"] == "1" for r in rs))
            os.kill(info["pid"], signal.SIGKILL)  # the emulator, and with it its JACK server
            health = wait_until(lambda: (h := server.get("/api/health"))["status"] == "degraded" and "device_missing"
                                in {r["code"] for r in h["reasons"]} and h, 10.0, "health degraded: device_missing")
            touching.result()
        assert any("audio" in r["message"] for r in health["reasons"] if r["code"] == "device_missing")
        assert audio_device(server)["status"] == "disconnected"
        assert api.ok("GET", f"/api/sessions/{sid}")["running"] is not None, "the trial runs on"
        link = Path(info["link"])
        emulator = subprocess.Popen(emulator_command("audio", link, Path(info["timeline"]), append_timeline=True,
                                                     jack_server=info["jack_server"]),
                                    stdout=subprocess.DEVNULL, cwd=Path(__file__).resolve().parents[2])
        wait_until(lambda: audio_device(server)["status"] == "connected", 60.0,
                   f"the audio tactor back (emulator exit code {emulator.poll()})")
        wait_until(lambda: server.get("/api/health")["status"] == "ok", 30.0, "health ok again")
        assert audio_device(server)["disconnects"] >= 1
        back = now_us()
        asyncio.run(drive(server.ws, ON_THE_PLANE, hold_s=1.0))
        rows = audio_rows(server, back, lambda rs: any(r["gate"] == "1" for r in rs))
        assert any(r["gate"] == "1" for r in rows), "the texture plays again on the returned tactor"
        api.ok("PUT", f"/api/sessions/{sid}/trials/{seq}/responses/rough", {"value": 5})
        finished = api.ok("POST", f"/api/sessions/{sid}/trials/{seq}/finish")
        assert (finished["status"], finished["attempt"]) == ("answered", 1), finished
    finally:
        stop_server(proc)
        if emulator is not None:
            emulator.terminate()
            emulator.wait(timeout=10)

    db = sqlite3.connect(data / "viestac.sqlite")
    tid = finished["id"]
    ticks = [t for (t,) in db.execute("SELECT tick FROM samples WHERE trial_id = ? ORDER BY tick", (tid,))]
    assert ticks and ticks[0] <= finished["started_tick"] + 5 and ticks[-1] >= finished["ended_tick"] - 5
    gaps = [b - a for a, b in zip(ticks, ticks[1:])]
    assert max(gaps) <= 5 * 3, f"rows missing across the audio server's death (largest tick gap {max(gaps)})"
    assert db.execute("SELECT COUNT(*) FROM samples WHERE trial_id = ? AND contact = 1", (tid,)).fetchone()[0] > 0
    kinds = {k for (k,) in db.execute("SELECT kind FROM events WHERE trial_id = ?", (tid,))}
    assert not kinds & {"interrupted", "dropped"}, kinds
    db.close()
