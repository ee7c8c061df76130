"""`viestac serve --rig audio`: the audio server dying mid-trial makes health degraded (the texture
scenario needs the audio tactor), and the device is back when the server is. A module of its own,
so no other server runs beside it."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
from pathlib import Path

import pytest

from devices.rig import emulator_command
from tests.audio.test_audio_live import audio_device, wait_until
from tests.integration.test_scenarios_live import Server
from tests.live_server import start_server, stop_server

pytestmark = pytest.mark.skipif(shutil.which("jackd") is None, reason="jackd is not installed (Debian: jackd2)")


def test_the_audio_server_dying_mid_trial_degrades_health_until_it_is_back():
    pytest.importorskip("jack")
    pytest.importorskip("sounddevice")
    proc, base = start_server("texture", extra=["--rig", "audio"], timeout_s=120.0)
    emulator = None
    try:
        server = Server(base)
        wait_until(lambda: audio_device(server)["status"] == "connected", 60.0, "the audio tactor")
        wait_until(lambda: server.get("/api/health")["status"] == "ok", 30.0, "health ok")
        info = server.get("/api/devices")["simulated_rig"]["emulators"]["audio"]
        os.kill(info["pid"], signal.SIGKILL)  # the emulator, and with it its JACK server
        health = wait_until(lambda: (h := server.get("/api/health"))["status"] == "degraded" and "device_missing" in
                            {r["code"] for r in h["reasons"]} and h, 10.0, "health degraded: device_missing")
        assert any("audio" in r["message"] for r in health["reasons"] if r["code"] == "device_missing")
        assert audio_device(server)["status"] == "disconnected"
        link = Path(info["link"])
        emulator = subprocess.Popen(emulator_command("audio", link, Path(info["timeline"]), append_timeline=True,
                                                     jack_server=info["jack_server"]),
                                    stdout=subprocess.DEVNULL, cwd=Path(__file__).resolve().parents[2])
        wait_until(lambda: audio_device(server)["status"] == "connected", 60.0,
                   f"the audio tactor back (emulator exit code {emulator.poll()})")
        wait_until(lambda: server.get("/api/health")["status"] == "ok", 30.0, "health ok again")
        assert audio_device(server)["disconnects"] >= 1
    finally:
        stop_server(proc)
        if emulator is not None:
            emulator.terminate()
            emulator.wait(timeout=10)
