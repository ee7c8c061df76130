"""The real server with real `websockets` clients (msgpack and JSON), as a client would use it."""

from __future__ import annotations

import asyncio
import csv
import json
import math
import socket
import time
from pathlib import Path

import msgpack
import pytest
import websockets

from server.hub.session import HELLO_TIMEOUT_NS
from tests.live_server import admin_token

VECTORS = Path(__file__).parents[1] / "vectors"
INVALID = json.loads((VECTORS / "invalid.json").read_text())["frames"]
MSGPACK = "viestac.v1.msgpack"
JSON = "viestac.v1.json"


def run(coro):
    return asyncio.run(coro)


_ADMIN = object()  # Client.connect's default token: the harness's admin token for that server


class Client:
    """A protocol v1 client over a real WebSocket, decoding either format. Its hello carries the
    admin token the harness made for that server (which holds the control lease), unless `token`
    says otherwise (None: no token)."""

    def __init__(self, ws, fmt: str):
        self.ws, self.fmt = ws, fmt

    @classmethod
    async def connect(cls, url: str, fmt: str = "msgpack", role: str = "participant", hello: bool = True,
                      token=_ADMIN):
        # max_queue=None: a test that stops reading must still see the server's close frame
        # (with a bounded queue, reading pauses and close() waits for its 10 s timeout).
        ws = await websockets.connect(url, subprotocols=[MSGPACK if fmt == "msgpack" else JSON],
                                      compression=None, max_size=1 << 21, max_queue=None)
        client = cls(ws, fmt)
        if hello:
            message = {"type": "hello", "v": 1, "role": role, "client": "pytest"}
            token = admin_token(url) if token is _ADMIN else token
            if token is not None:
                message["token"] = token
            await client.send(message)
        return client

    async def send(self, message: dict) -> None:
        await self.ws.send(msgpack.packb(message) if self.fmt == "msgpack" else json.dumps(message))

    async def recv(self, timeout: float = 3.0) -> dict:
        data = await asyncio.wait_for(self.ws.recv(), timeout)
        if self.fmt == "msgpack":
            assert isinstance(data, bytes), "msgpack connections get binary frames"
            return msgpack.unpackb(data)
        assert isinstance(data, str), "JSON connections get text frames"
        return json.loads(data)

    async def recv_type(self, kind: str, timeout: float = 3.0) -> dict:
        deadline = time.monotonic() + timeout
        while True:
            message = await self.recv(max(0.01, deadline - time.monotonic()))
            if message["type"] == kind:
                return message

    async def close(self) -> None:
        await self.ws.close()


async def _state_rate(url: str, fmt: str, seconds: float = 3.0) -> tuple[dict, dict, float]:
    """The rate the server publishes state at, on the loop's clock: frames (the publish counter) per
    second of loop ticks over `seconds`. The test's own clock would count how fast a loaded
    machine lets this client read, not what the server sends."""
    client = await Client.connect(url, fmt)
    welcome = await client.recv()
    scene = await client.recv()
    first = last = await client.recv_type("state")
    start = time.monotonic()
    while time.monotonic() - start < seconds:
        message = await client.recv()
        if message["type"] == "state":
            last = message
    rate = (last["frame"] - first["frame"]) / ((last["tick"] - first["tick"]) / welcome["tick_hz"])
    await client.close()
    return welcome, scene, rate


@pytest.mark.parametrize("fmt", ["msgpack", "json"])
def test_welcome_scene_then_state_at_60_hz(live_server, fmt):
    welcome, scene, rate = run(_state_rate(live_server.ws_url, fmt))
    assert welcome["type"] == "welcome" and welcome["v"] == 1 and welcome["format"] == fmt
    assert welcome["role"] == "participant" and welcome["tick_hz"] == 1000
    assert scene["type"] == "scene"
    ids = {o["id"] for o in scene["scene"]["objects"]}
    assert {"ground", "hemisphere"} <= ids
    assert scene["scene"]["camera"]["projection"] == "orthographic"
    assert 57.0 <= rate <= 63.0, f"state rate {rate:.1f} Hz"


def test_state_frame_fields_and_telemetry(live_server):
    async def go():
        client = await Client.connect(live_server.ws_url)
        scene = await client.recv_type("scene")
        state = await client.recv_type("state")
        await client.close()
        return scene, state

    scene, state = run(go())
    assert state["scene"] == scene["hash"]
    for key in ("frame", "tick", "t", "hip", "proxy", "force", "contact", "contacts", "objects", "cues", "hud",
                "values", "telemetry"):
        assert key in state
    telemetry = state["telemetry"]
    assert telemetry["ticks"] > 0 and telemetry["period_p50_us"] > 0
    health = live_server.get("/api/health")
    assert health["status"] == "ok" and health["loop"]["alive"]
    assert health["telemetry"]["ticks"] > 0


def _on_dome(angle_deg: float, inset: float = 0.003) -> list[float]:
    """A HIP at contact angle `angle_deg` (Algorithm 1), `inset` inside the proxy-dilated dome."""
    r = 0.6 + 0.06 - inset
    a = math.radians(angle_deg)
    return [0.0, r * math.sin(a), r * math.cos(a)]


def test_tracker_along_the_arc_moves_angle_and_tilt_commands(live_server):
    angles = [-70.0, -30.0, 0.0, 30.0, 70.0]

    async def go():
        client = await Client.connect(live_server.ws_url)
        await client.recv_type("scene")
        seen = {}
        seq = 0
        for angle in angles:
            deadline = time.monotonic() + 3.0
            while time.monotonic() < deadline:
                await client.send({"type": "tracker", "seq": seq, "t": time.monotonic() * 1e3, "pos": _on_dome(angle)})
                seq += 1
                state = await client.recv_type("state")
                value = state["values"].get("angle_deg")
                if value is not None and abs(value - angle) < 0.5:
                    seen[angle] = state
                    # Held for a moment, as a hand would: the device shows the newest cue (latest
                    # wins), so an angle left within a few ms may never reach it.
                    await asyncio.sleep(0.1)
                    break
                await asyncio.sleep(0.01)
        # the devices while the HIP still touches the dome: when its driver leaves, the HIP goes home
        devices = await asyncio.to_thread(live_server.get, "/api/devices")
        await client.close()
        return seen, devices

    seen, devices = run(go())
    assert set(seen) == set(angles), f"angles reached: {sorted(seen)}"
    for angle, state in seen.items():
        tilt = [c for c in state["cues"] if c["kind"] == "tilt"]
        assert tilt and abs(tilt[0]["direction_deg"] - (-angle) % 360) < 0.5
        assert state["contact"] is True
    # The simulated rig's FerroVibe emulator (through pyserial on a pty) tilted the magnet accordingly.
    timeline = Path(devices["simulated_rig"]["emulators"]["ferrovibe"]["timeline"])
    deadline = time.monotonic() + 10  # the emulator flushes its timeline every 0.2 s, later on a loaded machine
    while True:
        with timeline.open() as f:
            directions = [float(row["direction_deg"]) for row in csv.DictReader(f) if float(row["magnitude_pct"]) > 0]
        if all(any(abs(d - (-a) % 360) < 0.6 for d in directions) for a in angles) or time.monotonic() > deadline:
            break
        time.sleep(0.1)
    for angle in angles:
        assert any(abs(d - (-angle) % 360) < 0.6 for d in directions), f"no tilt near {(-angle) % 360} in the timeline"
    # The FingerTac cannot show a tilt: it says so in the console; the participant is not told,
    # because the FerroVibe beside it shows the tilt (only cues no device shows reach the HUD).
    refusals = [r for r in devices["refusals"] if r["device"] == "fingertac"]
    assert refusals and refusals[0]["code"] == "not_displayed" and refusals[0]["cue"] == "tilt"
    assert not any(refusals[0]["reason"] in s["hud"] for s in seen.values())


def test_tracker_reaches_server_counters(live_server):
    async def go():
        client = await Client.connect(live_server.ws_url, "json")
        await client.recv_type("welcome")
        for seq in range(5):
            await client.send({"type": "tracker", "seq": seq, "t": 1.5, "pos": [0.5, 0.1, 1.0]})
        await asyncio.sleep(0.3)
        clients = live_server.get("/api/clients")
        await client.close()
        return clients

    clients = run(go())
    mine = [c for c in clients if c["format"] == "json" and c["tracker_count"] == 5]
    assert mine and mine[0]["last_tracker"]["pos"] == [0.5, 0.1, 1.0]


async def _expect_error(client: Client, code: str) -> dict:
    message = await client.recv_type("error")
    assert message["code"] == code, message
    assert message["message"]
    return message


def test_bad_frames_get_errors_and_serving_goes_on(live_server):
    async def go():
        bad = await Client.connect(live_server.ws_url)
        await bad.recv_type("scene")
        watcher = await Client.connect(live_server.ws_url, role="observer")
        await watcher.recv_type("scene")
        before = live_server.get("/api/health")["telemetry"]
        for frame in INVALID:
            await bad.ws.send(bytes.fromhex(frame["msgpack_hex"]))
            await _expect_error(bad, frame["code"])
        await bad.ws.send(b"\x81\xa4type\xa5input" + b"\x00" * (64 * 1024))
        await _expect_error(bad, "too_large")
        await bad.ws.send('{"type":"tracker"}')  # text on a msgpack connection
        await _expect_error(bad, "bad_encoding")
        # The flooding connection still gets state, and so does the other client.
        await bad.recv_type("state")
        await watcher.recv_type("state")
        await asyncio.sleep(1.2)
        after = live_server.get("/api/health")["telemetry"]
        await bad.close()
        await watcher.close()
        return before, after

    before, after = run(go())
    # The loop kept ticking at ~1 kHz while the hub refused the bad frames.
    assert after["ticks"] - before["ticks"] >= 900


def test_json_client_bad_input(live_server):
    async def go():
        client = await Client.connect(live_server.ws_url, "json")
        await client.recv_type("scene")
        await client.ws.send("{not json")
        await _expect_error(client, "bad_encoding")
        await client.ws.send('{"type":"tracker","seq":1,"t":0,"pos":[NaN,0,0]}')
        await _expect_error(client, "non_finite")
        await client.ws.send('{"type":"tracker","seq":1,"t":0,"pos":[0,0,"x"]}')
        await _expect_error(client, "bad_message")
        await client.ws.send(b"\x80")  # binary on a JSON connection
        await _expect_error(client, "bad_encoding")
        await client.ws.send('{"type":"ping"}')
        await _expect_error(client, "unknown_type")
        await client.recv_type("state")
        await client.close()

    run(go())


def test_observer_may_not_send_tracker_and_bad_version_closes(live_server):
    async def go():
        observer = await Client.connect(live_server.ws_url, role="observer")
        await observer.recv_type("scene")
        await observer.send({"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 1]})
        await _expect_error(observer, "forbidden")
        await observer.close()
        future = await Client.connect(live_server.ws_url, hello=False)
        await future.send({"type": "hello", "v": 2, "role": "participant", "client": "from-the-future"})
        await _expect_error(future, "unsupported_version")
        with pytest.raises(websockets.ConnectionClosed) as info:
            for _ in range(100):
                await future.recv()
        assert info.value.rcvd is not None and info.value.rcvd.code == 1002

    run(go())


def test_client_without_hello_is_refused_at_the_grace_deadline(live_server):
    """v1.3: a client without a hello has no token (it was welcomed as an observer up to v1.2)."""
    async def go():
        client = await Client.connect(live_server.ws_url, hello=False)
        error = await client.recv(timeout=HELLO_TIMEOUT_NS / 1e9 + 3.0)
        with pytest.raises(websockets.ConnectionClosed) as info:
            await client.recv(timeout=3.0)
        return error, info.value.rcvd

    error, close = run(go())
    assert error["type"] == "error" and error["code"] == "unauthorized"
    assert close is not None and close.code == 1008


def test_slow_client_does_not_hold_back_others(live_server):
    async def go():
        # A client that never reads: its frames are dropped (latest-wins), others keep 60 Hz.
        slow = await websockets.connect(live_server.ws_url, subprotocols=[MSGPACK], compression=None, max_queue=1,
                                        close_timeout=0.2)
        _, _, rate = await _state_rate(live_server.ws_url, "msgpack", seconds=2.0)
        await slow.close()
        return rate

    rate = run(go())
    assert 57.0 <= rate <= 63.0


def test_rest_endpoints(live_server):
    scenarios = live_server.get("/api/scenarios")
    assert any(s["id"] == "contact-angle-v1" for s in scenarios)
    scene = live_server.get("/api/scene")
    assert scene["scene"]["name"] == "contact-angle"
    openapi = live_server.get("/openapi.json")
    assert "/api/health" in openapi["paths"]
    telemetry = live_server.get("/api/telemetry")
    assert telemetry["ticks"] > 0


def test_departed_clients_leave_the_table_at_once(live_server):
    async def go():
        client = await Client.connect(live_server.ws_url, role="observer")
        welcome = await client.recv_type("welcome")
        await client.close()
        await asyncio.sleep(0.3)
        return welcome["client_id"], live_server.get("/api/clients")

    client_id, clients = run(go())
    assert client_id not in {c["client_id"] for c in clients}


def test_a_tracker_bridge_on_the_udp_port_drives_the_loop_and_the_devices(live_server):
    """Samples sent to the tracker UDP port (no WebSocket) move the HIP, show in /api/trackers
    under the sender's address, and reach the FerroVibe as a tilt; a bad datagram gets an error."""
    host, port = live_server.get("/api/health")["tracker_udp"].rsplit(":", 1)

    async def go():
        viewer = await Client.connect(live_server.ws_url, role="observer")
        await viewer.recv_type("scene")
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as bridge:
            bridge.settimeout(2.0)
            bridge.sendto(b'{"type":"tracker","seq":0,"t":0,"pos":[0,0]}', (host, int(port)))
            error = json.loads(bridge.recv(2048))
            state = None
            for seq in range(1, 200):
                bridge.sendto(msgpack.packb({"type": "tracker", "seq": seq, "t": time.monotonic() * 1e3,
                                             "pos": _on_dome(40.0)}), (host, int(port)))
                state = await viewer.recv_type("state")
                if state["values"].get("angle_deg") is not None and abs(state["values"]["angle_deg"] - 40.0) < 0.5:
                    break
            name = "udp:127.0.0.1:%d" % bridge.getsockname()[1]
        await viewer.close()
        return error, state, name

    error, state, name = run(go())
    assert error["type"] == "error" and error["code"] == "bad_message"
    assert state["contact"] is True and abs(state["hip"][1] - _on_dome(40.0)[1]) < 1e-9
    rows = live_server.get("/api/trackers?limit=4096")["rows"]
    mine = [r for r in rows if r[0] == name]
    assert mine and mine[-1][3] <= mine[-1][4], "read by the loop at the start of the tick that applied it"
    tilts = [c for c in state["cues"] if c["kind"] == "tilt"]
    assert tilts and abs(tilts[0]["direction_deg"] - 320.0) < 0.5
    feed = live_server.get("/api/devices")["feed"]
    assert feed["records"] > 0 and feed["delay"]["handed_over"]["max_us"] > 0
