"""An audio tactor in the real server: `viestac serve --rig ferrovibe,audio` (the audio tactor in
FingerTac's place) runs the contact-angle and texture scenarios, checked where they end: in the
audio emulator's timeline (a JACK dummy server and a capture of ViESTac's output ports)."""

from __future__ import annotations

import asyncio
import csv
import shutil
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from tests.integration.test_scenarios_live import Server, drive, lift, now_us
from tests.live_server import start_server, stop_server

pytestmark = pytest.mark.skipif(shutil.which("jackd") is None, reason="jackd is not installed (Debian: jackd2)")


def audio_rows(server: Server, since_us: int, until, timeout_s: float = 10.0) -> list[dict]:
    path = Path(server.get("/api/devices")["simulated_rig"]["emulators"]["audio"]["timeline"])
    deadline = time.monotonic() + timeout_s
    while True:
        with path.open() as f:
            rows = [r for r in csv.DictReader(f) if int(r["t_us"]) >= since_us]
        if until(rows) or time.monotonic() > deadline:
            return rows
        time.sleep(0.1)


def audio_device(server: Server) -> dict:
    return next(d for d in server.get("/api/devices")["devices"] if d["name"] == "audio")


def wait_until(predicate, timeout_s: float, what: str):
    deadline = time.monotonic() + timeout_s
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.1)


@pytest.fixture(scope="module")
def server():
    pytest.importorskip("jack")
    pytest.importorskip("sounddevice")
    proc, base = start_server("contact-angle", extra=["--rig", "ferrovibe,audio"], timeout_s=120.0)
    try:
        s = Server(base)
        wait_until(lambda: audio_device(s)["status"] == "connected", 60.0, "the audio tactor")
        yield s
    finally:
        stop_server(proc)


def test_texture_plays_on_the_audio_tactor_as_its_own_waveform(server):
    server.switch("texture", period_us=3000)
    lift(server)
    t0 = now_us()
    state = asyncio.run(drive(server.ws, [(0.0, 0.2, 0.5), (0.0, 0.2, 0.03)], hold_s=1.0))
    lift(server)
    assert state["cues"] == [{"kind": "texture", "period_us": 3000.0, "duty": 0.5, "intensity_pct": 100.0}]
    rows = audio_rows(server, t0, lambda rs: any(r["gate"] == "1" for r in rs) and rs[-1]["gate"] == "0")
    playing = [r for r in rows if r["channel"] == "out_1" and r["gate"] == "1" and float(r["frequency_hz"]) > 0]
    assert playing, f"no texture at the audio port: {rows[:10]}"
    # the texture's own waveform: a rectangle at 1/period = 333.3 Hz, full drive
    assert any(abs(float(r["frequency_hz"]) - 333.3) < 2.0 for r in playing), playing[:10]
    assert max(float(r["peak"]) for r in playing) == pytest.approx(1.0, abs=0.01)
    assert rows[-1]["gate"] == "0", "silent again after the lift"


def test_contact_angle_runs_and_the_audio_tactor_refuses_the_tilt_with_a_reason(server):
    server.switch("contact-angle")
    lift(server)
    t0 = now_us()
    with ThreadPoolExecutor(1) as pool:  # on the dome for 3 s; meanwhile ask the server
        touching = pool.submit(asyncio.run, drive(server.ws, [(0.0, 0.0, 2.0), (0.0, 0.33, 0.57)], hold_s=3.0))
        refusals = wait_until(lambda: audio_device(server)["refusals"], 20.0, "the audio tactor's refusal")
        state = touching.result()
    lift(server)
    assert state["cues"] and state["cues"][0]["kind"] == "tilt"
    assert [r["code"] for r in refusals] == ["not_displayed"]
    assert "audio (audio) cannot show the tilt cue" in refusals[0]["reason"]
    ferro = Path(server.get("/api/devices")["simulated_rig"]["emulators"]["ferrovibe"]["timeline"])
    with ferro.open() as f:
        assert any(int(r["t_us"]) >= t0 and float(r["magnitude_pct"]) > 0 for r in csv.DictReader(f)), \
            "the FerroVibe beside it tilts"
    rows = audio_rows(server, t0, lambda rs: False, timeout_s=0.5)
    assert not any(r["gate"] == "1" for r in rows), "the audio tactor stays silent for a tilt"
