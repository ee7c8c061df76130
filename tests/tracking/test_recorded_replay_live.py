"""Every session records the samples it used, so a trial replays through `viestac render`: a real
server tracks a replayed finger path (`--tracker replay:`, through the tracker host, calibration and
1€ filter) pressing into the contact-angle dome, records one trial of a session at every tick,
`viestac export` writes it, and `viestac render` of the exported trajectory computes the same HIP,
proxy and contact tick by tick; the same file is a `--tracker replay:` source."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
import time
import urllib.request

import pytest

from scenarios.contact_angle import point_at_angle
from tests.live_server import auth_headers, get_json, start_server, stop_server
from server.tracking import replay

pytestmark = pytest.mark.slow

STUDY = """id = "replay-check"
title = "a trial recorded from a replayed tracker"
seed = 1
participants = 1

[[tasks]]
id = "hold"
scenario = "contact-angle"
device = "ferrovibe"
conditions = [{ time_limit_s = 600.0 }]
repetitions = 1
order = "fixed"
"""
TOUCH, AWAY = 0.6 + 0.06 - 0.02, 0.6 + 0.06 + 0.1


def path_csv(rate: float = 100.0, seconds: float = 1.2) -> str:
    """Hover, press in at 30°, slide to -20° while pressed, lift: looped by the replay source."""
    times, rows = [], []
    n = int(rate * seconds)
    for i in range(n):
        phase = i / n
        if phase < 0.25 or phase >= 0.8:
            p = point_at_angle(30.0 if phase < 0.25 else -20.0, AWAY)
        else:
            p = point_at_angle(30.0 - 50.0 * (phase - 0.25) / 0.55, TOUCH)
        times.append(i / rate)
        rows.append({"right.index.tip": p})
    return replay.write_csv(times, rows)


def call(base: str, method: str, path: str, body: dict | None = None, token: str | None = None) -> dict:
    headers = {"Content-Type": "application/json", **auth_headers(base), **({"X-Control-Token": token} if token else {})}
    request = urllib.request.Request(base + path, data=json.dumps(body).encode() if body is not None else None,
                                     method=method, headers=headers)
    with urllib.request.urlopen(request, timeout=10) as response:
        return json.loads(response.read())


def read(path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_a_recorded_trial_replays_through_render_tick_by_tick(tmp_path):
    (tmp_path / "studies").mkdir()
    (tmp_path / "studies" / "replay-check.toml").write_text(STUDY)
    source = tmp_path / "press.csv"
    source.write_text(path_csv())
    data = tmp_path / "data"
    proc, base = start_server("contact-angle", extra=["--tracker", f"replay:{source}", "--record-every", "1",
                                                      "--studies", str(tmp_path / "studies"), "--data-dir", str(data)])
    try:
        deadline = time.monotonic() + 10
        while get_json(base + "/api/trackers?limit=1")["sources"][0]["status"] != "ok":
            assert time.monotonic() < deadline, "the replay source never streamed"
            time.sleep(0.05)
        session = call(base, "POST", "/api/sessions", {"study": "replay-check", "participant": "R1",
                                                       "experimenter": "test", "device": "ferrovibe"})
        sid, token = session["id"], session["token"]
        call(base, "POST", f"/api/sessions/{sid}/trials/0/start", token=token)
        time.sleep(3.0)  # two and a half passes of the path: presses, slides, lifts
        call(base, "POST", f"/api/sessions/{sid}/trials/0/finish", token=token)
        out = tmp_path / "export"
        subprocess.run([sys.executable, "-m", "server.cli", "export", sid, "--out", str(out), "--data-dir", str(data)],
                       check=True, capture_output=True)
    finally:
        stop_server(proc)

    [trajectory] = list(out.glob("*/trajectories/trial_0_attempt_1.csv"))
    recorded = read(trajectory)
    ticks = [int(r["tick"]) for r in recorded]
    assert len(recorded) > 2000 and ticks == list(range(ticks[0], ticks[0] + len(ticks))), "every tick recorded"
    assert any(r["contact"] == "1" for r in recorded) and any(r["contact"] == "0" for r in recorded)

    rendered_path = tmp_path / "rendered.csv"
    subprocess.run([sys.executable, "-m", "server.cli", "render", "--scene", "contact-angle", "--trajectory",
                    str(trajectory), "--out", str(rendered_path)], check=True, capture_output=True)
    rendered = read(rendered_path)
    assert len(rendered) == len(recorded)
    for rec, ren in zip(recorded, rendered):
        for axis in "xyz":
            assert abs(float(ren[f"hip_{axis}"]) - float(rec[f"hip_{axis}"])) <= 1e-9, (rec, ren)
    # The render starts from a fresh god-object; once the finger has been in free space for a
    # while (proxy = HIP, the contact gate settled) both run the same simulation on the same samples.
    free = next(i for i, r in enumerate(recorded) if r["contact"] == "0" and i > 0) + 200
    compared = 0
    for rec, ren in zip(recorded[free:], rendered[free:]):
        assert ren["contact"] == rec["contact"], (rec, ren)
        for axis in "xyz":
            assert abs(float(ren[f"proxy_{axis}"]) - float(rec[f"proxy_{axis}"])) <= 1e-6, (rec, ren)
        compared += 1
    assert compared > 1500 and any(r["contact"] == "1" for r in recorded[free:]), "contacts were compared"

    # the same file is a replay source: its samples are the recorded HIP, on the recorded clock
    track = replay.parse_csv(trajectory.read_text(), where=str(trajectory))
    assert len(track.rows) == len(recorded)
    assert track.rows[5]["right.index.tip"] == tuple(float(recorded[5][f"hip_{a}"]) for a in "xyz")
    assert track.times[1] - track.times[0] == pytest.approx(0.001)
