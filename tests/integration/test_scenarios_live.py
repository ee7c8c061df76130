"""Each tactile-property scenario on the real server, driven by a scripted tracker over WebSocket,
checked where it ends: in the actuator timeline of the emulated device (the firmware core behind a
pty, reached through pyserial), not only in the server's values.

One server for the module, with the simulated rig extended by the devkit (temperature, friction).
Scenarios are switched and trials started through the REST API, as the experimenter's console does.
"""

from __future__ import annotations

import asyncio
import csv
import statistics
import time
import urllib.error
from pathlib import Path

import pytest

from server.bench.loop_bench import get_json, start_server, stop_server
from tests.integration.test_server_ws import Client


class Server:
    def __init__(self, base: str):
        self.http, self.ws = base, base.replace("http://", "ws://") + "/ws"

    def get(self, path: str):
        return get_json(self.http + path)

    def post(self, path: str, body: dict):
        return get_json(self.http + path, "POST", body=body)

    def switch(self, name: str, **params) -> dict:
        answer = self.post("/api/scenario", {"name": name, "params": params})
        deadline = time.monotonic() + 5.0
        while (self.get("/api/scenario").get("id"), self.get("/api/scenario").get("params")) != \
                (answer["id"], answer["params"]):
            assert time.monotonic() < deadline, f"the loop did not switch to {name}"
            time.sleep(0.02)
        return answer

    def timeline(self, model: str, since_us: int, until=lambda rows: bool(rows), timeout_s: float = 3.0) -> list[dict]:
        """Timeline rows of an emulated device since a CLOCK_MONOTONIC time, once `until` holds
        (the emulators flush their CSV every 0.2 s)."""
        path = Path(self.get("/api/devices")["simulated_rig"]["emulators"][model]["timeline"])
        deadline = time.monotonic() + timeout_s
        while True:
            with path.open() as f:
                rows = [r for r in csv.DictReader(f) if int(r["t_us"]) >= since_us]
            if until(rows) or time.monotonic() > deadline:
                return rows
            time.sleep(0.1)


@pytest.fixture(scope="module")
def server():
    proc, base = start_server("contact-angle", extra=["--rig", "fingertac,ferrovibe,devkit"])
    try:
        yield Server(base)
    finally:
        stop_server(proc)


def now_us() -> int:
    return time.monotonic_ns() // 1000


async def drive(url: str, waypoints, hold_s: float = 0.8, step=0.02, rate_hz=200.0) -> dict:
    """Move the HIP through `waypoints` in straight segments of at most `step` per sample, then
    hold the last one; returns the last state."""
    client = await Client.connect(url)
    await client.recv_type("scene")
    seq = 0
    points = [waypoints[0]]
    for a, b in zip(waypoints, waypoints[1:]):
        n = max(1, int(max(abs(b[i] - a[i]) for i in range(3)) / step))
        points += [tuple(a[i] + (b[i] - a[i]) * k / n for i in range(3)) for k in range(1, n + 1)]
    points += [points[-1]] * int(hold_s * rate_hz)
    for p in points:
        await client.send({"type": "tracker", "seq": seq, "t": time.time() * 1e3, "pos": list(p)})
        seq += 1
        await asyncio.sleep(1 / rate_hz)
    # frames queued while we were sending are old: read on for 0.2 s and keep the newest
    state = await client.recv_type("state")
    end = time.monotonic() + 0.2
    while time.monotonic() < end:
        state = await client.recv_type("state")
    await client.close()
    return state


def lift(server: Server) -> None:
    asyncio.run(drive(server.ws, [(0.0, 0.0, 2.5), (0.0, 0.0, 2.5)], hold_s=0.2))


def schedule_intervals_us(rows: list[dict], channel: str = "0") -> dict[str, list[int]]:
    """Durations of the on and off phases a pattern's scheduled edges produce."""
    edges = [r for r in rows if r["channel"] == channel and r["cause"] == "schedule"]
    out: dict[str, list[int]] = {"on": [], "off": []}
    for a, b in zip(edges, edges[1:]):
        out["on" if a["gate"] == "1" else "off"].append(int(b["t_us"]) - int(a["t_us"]))
    return out


def test_contact_angle_tap_reaches_the_ferrovibe_and_participants_cannot_tap(server):
    server.switch("contact-angle")

    async def go():
        part = await Client.connect(server.ws)
        op = await Client.connect(server.ws, role="operator")
        await part.send({"type": "input", "key": "tap_angle", "action": "press", "value": -30})
        forbidden = await part.recv_type("error")
        await op.send({"type": "input", "key": "tap_angle", "action": "press", "value": 135})
        out_of_range = await op.recv_type("error")
        await op.send({"type": "input", "key": "tap_angle", "action": "press"})
        no_value = await op.recv_type("error")
        t0 = now_us()
        await op.send({"type": "input", "key": "tap_angle", "action": "press", "value": -30})
        tapped = None
        for _ in range(200):
            state = await op.recv_type("state")
            if state["values"].get("tap_deg") == -30 and state["cues"]:
                tapped = state
                break
        await op.send({"type": "input", "key": "release", "action": "press"})
        await part.close()
        await op.close()
        return forbidden, out_of_range, no_value, tapped, t0

    forbidden, out_of_range, no_value, tapped, t0 = asyncio.run(go())
    assert forbidden["code"] == "forbidden" and "experimenter command" in forbidden["message"]
    assert out_of_range["code"] == "bad_message" and "[-90.0, 90.0]" in out_of_range["message"]
    assert no_value["code"] == "bad_message" and "needs a value" in no_value["message"]
    assert tapped is not None and tapped["values"]["angle_deg"] == pytest.approx(-30.0, abs=1e-6)
    assert [e["name"] for e in tapped["events"]] in ([], ["tap"])
    rows = server.timeline("ferrovibe", t0, lambda rs: any(float(r["magnitude_pct"]) == 100 for r in rs))
    tilted = [r for r in rows if float(r["magnitude_pct"]) == 100]
    assert tilted and float(tilted[0]["direction_deg"]) == pytest.approx(30.0, abs=0.01)


def test_texture_plays_on_both_devices_while_the_plane_moves(server):
    server.switch("texture", period_us=3000)
    lift(server)
    t0 = now_us()
    state = asyncio.run(drive(server.ws, [(0.0, 0.2, 0.5), (0.0, 0.2, 0.03)], hold_s=1.0))
    t1 = now_us()
    lift(server)
    assert state["cues"] == [{"kind": "texture", "period_us": 3000.0, "duty": 0.5, "intensity_pct": 100.0}]
    (plane,) = [o for o in state["objects"] if o[0] == "plane"]
    assert 0.05 < plane[1][1] < 0.15, "moved at 0.1 units/s for about a second"
    # FerroVibe: texture natively, tilted 1500 µs / flat 1500 µs (P/2 each)
    rows = server.timeline("ferrovibe", t0, lambda rs: len(schedule_intervals_us(rs)["on"]) > 100)
    phases = schedule_intervals_us([r for r in rows if r["mode"] == "texture" and int(r["t_us"]) <= t1])
    assert len(phases["on"]) > 100
    assert statistics.median(phases["on"]) == pytest.approx(1500, abs=2)
    assert statistics.median(phases["off"]) == pytest.approx(1500, abs=2)
    # FingerTac: fine roughness "(!)": continuous vibration at the texture's 333 Hz
    tac = server.timeline("fingertac", t0, lambda rs: any(r["mode"] == "continuous" for r in rs))
    assert any(r["mode"] == "continuous" and r["carrier_hz"] == "333" for r in tac)


def test_stiffness_level_becomes_the_fingertac_pulse_rate(server):
    server.switch("stiffness")
    server.post("/api/trial", {"phase": "main", "params": {"mode": "estimation", "level": 4}})
    lift(server)
    t0 = now_us()
    state = asyncio.run(drive(server.ws, [(0.0, 0.0, 1.5), (0.0, 0.0, 0.84)], hold_s=1.6))
    lift(server)
    assert state["values"]["touching"] == "middle"
    assert state["cues"] == [{"kind": "stiffness", "k_n_per_m": 40.0, "relative": 1 / 3}]
    assert "how stiff" in state["hud"]
    rows = server.timeline("fingertac", t0, lambda rs: len(schedule_intervals_us(rs)["off"]) >= 3)
    phases = schedule_intervals_us([r for r in rows if r["mode"] == "pulse"])
    # level 4: 4 Hz → 50 ms on, 1000/4 − 50 = 200 ms off, on the firmware's microsecond timer
    assert phases["on"] and all(d == 50_000 for d in phases["on"])
    assert len(phases["off"]) >= 3 and all(d == 200_000 for d in phases["off"])


def test_shape_cube_sides_and_top_tilt_the_magnet(server):
    server.switch("shape")
    server.post("/api/trial", {"phase": "main", "params": {"shape": "cube", "hidden": True}})
    lift(server)
    t_left = now_us()
    left = asyncio.run(drive(server.ws, [(0.0, -1.0, 2.0), (0.0, -1.0, 0.5), (0.0, -0.54, 0.5)], hold_s=0.4))
    t_top = now_us()
    top = asyncio.run(drive(server.ws, [(0.0, -1.0, 0.5), (0.0, -1.0, 2.0), (0.0, 0.1, 2.0), (0.0, 0.1, 1.04)],
                            hold_s=0.4))
    lift(server)
    assert left["visible"]["cube"] is False and left["values"]["touching"] == "cube"
    assert left["cues"] == [{"kind": "tilt", "direction_deg": 90.0, "magnitude_pct": 100.0}]
    assert top["cues"] == [{"kind": "tilt", "direction_deg": 0.0, "magnitude_pct": 100.0}]
    rows = server.timeline("ferrovibe", t_left, lambda rs: any(
        float(r["magnitude_pct"]) == 100 and float(r["direction_deg"]) == 0 and int(r["t_us"]) > t_top for r in rs))
    tilts = [(int(r["t_us"]), float(r["direction_deg"])) for r in rows if float(r["magnitude_pct"]) == 100]
    assert any(d == 90.0 and t < t_top for t, d in tilts), "left face → 90° (right side of the fingerpad)"
    assert any(d == 0.0 and t > t_top for t, d in tilts), "top face → 0° (front)"


def test_friction_and_temperature_reach_the_devkit(server):
    server.switch("friction-temperature")
    lift(server)
    t0 = now_us()
    warm = asyncio.run(drive(server.ws, [(-0.8, 1.1, 1.5), (-0.8, 1.1, 0.84)], hold_s=0.5))
    lift(server)
    t1 = now_us()
    rough = asyncio.run(drive(server.ws, [(1.0, 0.0, 0.5), (1.0, 0.0, 0.02)], hold_s=0.5))
    lift(server)
    assert warm["cues"] == [{"kind": "temperature", "celsius": 40.0}]
    assert rough["cues"] == [{"kind": "friction", "coefficient": 0.6}] and rough["values"]["sticking"] is True
    rows = server.timeline("devkit", t0, lambda rs: any(r["friction"] == "0.6" for r in rs))
    assert any(r["temperature_c"] == "40.0" and int(r["t_us"]) < t1 for r in rows)
    assert any(r["friction"] == "0.6" and int(r["t_us"]) > t1 for r in rows)


def test_a_rig_that_cannot_show_the_scenario_refuses_it(live_server):
    with pytest.raises(urllib.error.HTTPError) as err:
        live_server.post("/api/scenario", {"name": "friction-temperature"})
    assert err.value.code == 409
    assert "needs a device that shows friction or temperature" in err.value.read().decode()
    assert live_server.get("/api/scenario")["id"] == "contact-angle-v1", "nothing switched"
