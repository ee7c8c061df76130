"""Each tactile-property scenario on the real server, driven by a scripted tracker over WebSocket,
checked where it ends: in the actuator timeline of the emulated device (the firmware core behind a
pty, reached through pyserial), not only in the server's values.

One server for the module, with the simulated rig extended by the devkit (temperature, friction).
Scenarios are switched and trials started through the REST API, as the experimenter's console does.
"""

from __future__ import annotations

import asyncio
import csv
import math
import statistics
import time
import urllib.error
from pathlib import Path

import pytest

from scenarios.positioning import ITEMS
from tests.live_server import get_json, start_server, stop_server
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
        deadline = time.monotonic() + 30.0  # a bound for a hung switch, not a speed check: a loaded machine builds slowly
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
        # hold the tap until the device shows it: released at once, the tilt toward 30° can be
        # superseded by "off" before the link carries it (the device gets the newest cue set)
        rows = await asyncio.to_thread(server.timeline, "ferrovibe", t0, lambda rs: any(
            float(r["magnitude_pct"]) == 100 and float(r["direction_deg"]) == 30.0 for r in rs))
        await op.send({"type": "input", "key": "release", "action": "press"})
        await part.close()
        await op.close()
        return forbidden, out_of_range, no_value, tapped, rows

    forbidden, out_of_range, no_value, tapped, rows = asyncio.run(go())
    assert forbidden["code"] == "forbidden" and "experimenter command" in forbidden["message"]
    assert out_of_range["code"] == "bad_message" and "[-90.0, 90.0]" in out_of_range["message"]
    assert no_value["code"] == "bad_message" and "needs a value" in no_value["message"]
    assert tapped is not None and tapped["values"]["angle_deg"] == pytest.approx(-30.0, abs=1e-6)
    assert [e["name"] for e in tapped["events"] if e["name"] != "input"] in ([], ["tap"])
    tilted = [(r["t_us"], float(r["direction_deg"])) for r in rows if float(r["magnitude_pct"]) == 100]
    assert any(d == 30.0 for _, d in tilted), f"no tilt toward 30° in the FerroVibe's timeline: {tilted}"


def test_texture_plays_on_both_devices_while_the_plane_moves(server):
    server.switch("texture", period_us=3000)
    lift(server)
    t0 = now_us()
    state = asyncio.run(drive(server.ws, [(0.0, 0.2, 0.5), (0.0, 0.2, 0.03)], hold_s=1.0))
    t1 = now_us()
    lift(server)
    assert state["cues"] == [{"kind": "texture", "period_us": 3000.0, "duty": 0.5, "intensity_pct": 100.0}]
    (plane,) = [o for o in state["objects"] if o[0] == "plane"]
    assert 0.05 < plane[1][1] < 0.3, "moved at 0.1 units/s for the second or so in contact"
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


# -- positioning (issue 5) ----------------------------------------------------------------------

HANG = 0.21  # the carried object hangs below the fingertip: half the cube + the proxy radius


async def send_path(client, waypoints, step=0.01, rate_hz=100.0, dwell=5, seq=0):
    """Straight segments between waypoints, sampled every `step`; each corner is sent `dwell`
    times so the loop surely applies it (skipped samples inside a segment do not change its length)."""
    for a, b in zip(waypoints, waypoints[1:]):
        n = max(1, math.ceil(max(abs(b[i] - a[i]) for i in range(3)) / step))
        for k in range(1, n + 1):
            await client.send({"type": "tracker", "seq": seq, "t": time.time() * 1e3,
                               "pos": [a[i] + (b[i] - a[i]) * k / n for i in range(3)]})
            seq += 1
            await asyncio.sleep(1 / rate_hz)
        for _ in range(dwell):
            await client.send({"type": "tracker", "seq": seq, "t": time.time() * 1e3, "pos": list(b)})
            seq += 1
            await asyncio.sleep(1 / rate_hz)
    return seq


async def hold(client, point, seconds, seq, rate_hz=100.0):
    for _ in range(int(seconds * rate_hz)):
        await client.send({"type": "tracker", "seq": seq, "t": time.time() * 1e3, "pos": list(point)})
        seq += 1
        await asyncio.sleep(1 / rate_hz)
    return seq


async def wait_for(client, predicate, timeout=5.0):
    deadline = time.monotonic() + timeout
    events = []
    while time.monotonic() < deadline:
        state = await client.recv_type("state", timeout=max(0.05, deadline - time.monotonic()))
        events += state["events"]
        if predicate(state, events):
            return state, events
    raise AssertionError("the expected state did not come")


def test_a_scripted_positioning_trial_pick_hold_go_insert_next(server):
    server.switch("positioning", cue="P1")
    lift(server)
    start, target = ITEMS[0].start, (*ITEMS[0].hole_at, 0.95)  # cube_a and the target over its square hole
    above_cube, lifted = (*start, 0.6), (*start, 0.8)
    at_target = (target[0], target[1], target[2] + HANG)
    inside = (target[0], target[1], 0.6)  # the cube's top 0.05 under the tube's rim: inserted

    async def go():
        client = await Client.connect(server.ws)
        await client.recv_type("scene")
        seq = await send_path(client, [(*start, 1.2), above_cube, (*start, 0.34)])
        _, picked = await wait_for(client, lambda s, e: s["values"].get("phase") == "carry")
        seq = await send_path(client, [(*start, 0.34), lifted, at_target], seq=seq)
        seq = await hold(client, at_target, 2.3, seq)
        go_state, events = await wait_for(client, lambda s, e: any(x["name"] == "go" for x in e) or
                                          s["values"].get("phase") == "go")
        over_rim = (inside[0], inside[1], 0.65)  # the cube's top 0.04 over the insertion depth: not yet in
        seq = await send_path(client, [at_target, over_rim], seq=seq)
        seq = await send_path(client, [over_rim, inside], step=1.0, seq=seq)  # one step in: its end is exact
        done, more = await wait_for(client, lambda s, e: any(x["name"] == "trial_done" for x in e))
        await client.send({"type": "input", "key": " ", "action": "down"})
        await client.send({"type": "input", "key": " ", "action": "up"})
        nxt, _ = await wait_for(client, lambda s, e: s["values"].get("object") == "sphere")
        await client.close()
        return go_state, picked + events + more, nxt

    go_state, events, nxt = asyncio.run(go())
    lift(server)
    assert go_state["hud"] == "GO"
    names = [e["name"] for e in events]
    assert names.index("reached") < names.index("go") < names.index("trial_done")
    done = next(e for e in events if e["name"] == "trial_done")
    # the object's path from the scripted corners: up from the table (clamped at 0.15), over, down
    corners = [(*start, 0.15), (*start, lifted[2] - HANG), target, (inside[0], inside[1], inside[2] - HANG)]
    expected = sum(math.dist(a, b) for a, b in zip(corners, corners[1:]))
    assert done["path_length"] == pytest.approx(expected, abs=1e-6)
    assert 0.0 <= done["hold_error_mean"] < 0.05, "the hold counts from the first tick within 0.05 of the target"
    ticks = {e["name"]: e["tick"] for e in events}
    assert done["completion_s"] == pytest.approx((ticks["trial_done"] - ticks["pick"]) / 1000, abs=1e-9)
    assert done["time_to_target_s"] == pytest.approx((ticks["reached"] - ticks["pick"]) / 1000, abs=1e-9)
    assert ticks["go"] - ticks["reached"] >= 2000
    assert nxt["values"]["phase"] == "idle" and nxt["hud"] == "Pick up the object"


@pytest.mark.parametrize("offset, direction", [
    ((0.0, 0.5, 0.0), 90.0), ((0.0, -0.5, 0.0), 270.0), ((0.5, 0.0, 0.0), 180.0), ((-0.5, 0.0, 0.0), 0.0),
    ((0.5, 0.5, 0.0), 135.0), ((0.5, -0.5, 0.0), 225.0), ((-0.5, 0.5, 0.0), 45.0), ((-0.5, -0.5, 0.0), 315.0),
])
def test_3dof_guidance_tilts_the_ferrovibe_per_octant_and_on_overshoot(server, offset, direction):
    server.switch("positioning", cue="3dof")
    lift(server)
    start, target = ITEMS[0].start, (*ITEMS[0].hole_at, 0.95)
    at = tuple(target[i] + offset[i] for i in range(3))
    hip = (at[0], at[1], at[2] + HANG)

    async def go():
        client = await Client.connect(server.ws)
        await client.recv_type("scene")
        seq = await send_path(client, [(*start, 1.2), (*start, 0.34)])
        await wait_for(client, lambda s, e: s["values"].get("phase") == "carry")
        seq = await send_path(client, [(*start, 0.34), (*start, 1.2), (hip[0], hip[1], 1.2), hip], step=0.05, seq=seq)
        t1 = now_us()
        await hold(client, hip, 0.3, seq)
        settled = math.dist(at, target)  # read on past the states of the approach
        state, _ = await wait_for(client, lambda s, e: abs(s["values"].get("distance", -1) - settled) < 1e-6)
        await client.close()
        return state, t1

    state, t1 = asyncio.run(go())
    lift(server)
    assert state["cues"][0]["direction_deg"] == direction
    rows = server.timeline("ferrovibe", t1, lambda rs: any(float(r["magnitude_pct"]) == 100 for r in rs))
    tilts = {float(r["direction_deg"]) for r in rows if float(r["magnitude_pct"]) == 100}
    assert direction in tilts, f"the magnet did not tilt to {direction}° (saw {sorted(tilts)})"


# -- hot wire (issue 5) -------------------------------------------------------------------------

def test_a_scripted_hot_wire_run_over_websocket(server):
    server.switch("hot-wire", points="0 -1 0.5; 0 1 0.5", threshold=0.06, max_distance=0.3)
    lift(server)
    start, end = (0.0, -1.0, 0.5), (0.0, 1.0, 0.5)
    trace = [start, (0.0, -0.3, 0.5), (0.0, -0.3, 0.6), (0.0, 0.3, 0.6), (0.0, 0.3, 0.5), (0.0, 0.8, 0.5)]

    async def go():
        client = await Client.connect(server.ws)
        await client.recv_type("scene")
        # one jump onto the start (the run starts exactly there), 0.1 above the wire for 0.6 units,
        # one last step onto the target (so both ends of the run are exact)
        seq = await send_path(client, [(0.0, -1.0, 1.5), start], step=1.0)
        _, started = await wait_for(client, lambda s, e: s["values"].get("phase") == "tracing")
        seq = await send_path(client, trace[:4], seq=seq)
        mid_state, events = await wait_for(client, lambda s, e: abs(s["values"]["deviation"] - 0.1) < 1e-9)
        seq = await send_path(client, trace[3:], seq=seq)
        seq = await send_path(client, [trace[-1], end], step=1.0, seq=seq)
        done_state, more = await wait_for(client, lambda s, e: any(x["name"] == "trial_done" for x in e))
        await client.close()
        return mid_state, done_state, started + events + more

    mid_state, done_state, events = asyncio.run(go())
    lift(server)
    cue = mid_state["cues"][0]
    assert cue["kind"] == "pulse_train" and cue["intensity_pct"] == pytest.approx(30 + 70 * (0.1 - 0.06) / 0.24)
    done = next(e for e in events if e["name"] == "trial_done")
    corners = trace + [end]
    assert done["path_length"] == pytest.approx(sum(math.dist(a, b) for a, b in zip(corners, corners[1:])), abs=1e-6)
    assert done["deviation_max"] == pytest.approx(0.1, abs=1e-9)
    assert 0.3 < done["time_outside_s"] < done["completion_s"], done
    ticks = {e["name"]: e["tick"] for e in events}
    assert done["completion_s"] == pytest.approx((ticks["trial_done"] - ticks["start"]) / 1000, abs=1e-9)
    assert done_state["values"]["time_outside_s"] == done["time_outside_s"], "the metrics are in the state too"
    assert done_state["hud"] == "Done: press r to go again"
