"""Issue 18 against a real server (its own, started here) with real `websockets` clients and a
real UDP tracker bridge: huge positions (defect 1), a key flood (defect 6), frames that once
closed the connection (defect 8) and one rule for both encodings (defect 9)."""

from __future__ import annotations

import asyncio
import json
import math
import socket
import statistics
import time

import msgpack
import pytest

from tests.live_server import get_json
from tests.integration.test_server_ws import Client, run

DOME_R = 0.66
HUGE = ([0, 1e154, 0.5], [0, 1.35e154, 0.5])
SANE = [0.1, 0.1, 0.5]  # inside the dome: the proxy must sit on its surface


@pytest.fixture(scope="module")
def server(own_server):
    return own_server.http_url


def _ws(base: str) -> str:
    return base.replace("http://", "ws://") + "/ws"


def _on_dome(proxy) -> bool:
    return abs(math.sqrt(sum(v * v for v in proxy)) - DOME_R) < 1e-6


async def _error(client: Client, timeout: float = 3.0) -> dict:
    return await client.recv_type("error", timeout)


async def _state_where(client: Client, predicate, timeout: float = 3.0) -> dict:
    deadline = time.monotonic() + timeout
    while True:
        state = await client.recv_type("state", max(0.01, deadline - time.monotonic()))
        if predicate(state):
            return state


def test_huge_positions_on_ws_are_refused_and_haptics_go_on(server):
    async def go():
        hand = await Client.connect(_ws(server))
        viewer = await Client.connect(_ws(server), role="observer")
        welcome = await hand.recv_type("welcome")
        await viewer.recv_type("scene")
        for seq, pos in enumerate(HUGE):
            await hand.send({"type": "tracker", "seq": seq, "t": 0, "pos": pos})
            error = await _error(hand)
            assert error["code"] == "out_of_range" and "pos" in error["message"]
        await hand.send({"type": "tracker", "seq": 2, "t": 0, "pos": SANE})
        mine = await _state_where(viewer, lambda s: s["driver"] == [welcome["client_id"], 2])
        assert mine["hip"] == SANE and _on_dome(mine["proxy"]) and mine["contact"] is not None
        ticks = get_json(server + "/api/health")["telemetry"]["ticks"]
        await asyncio.sleep(0.5)
        assert get_json(server + "/api/health")["telemetry"]["ticks"] > ticks, "the loop still ticks"
        await hand.close()
        await viewer.close()
    run(go())


def test_huge_positions_on_the_udp_port_are_refused_and_haptics_go_on(server):
    host, port = get_json(server + "/api/health")["tracker_udp"].rsplit(":", 1)

    async def go():
        viewer = await Client.connect(_ws(server), role="observer")
        await viewer.recv_type("scene")
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as bridge:
            bridge.settimeout(2.0)
            bridge.bind(("127.0.0.1", 0))
            source = "udp:%s:%d" % bridge.getsockname()
            for seq, pos in enumerate(HUGE):
                bridge.sendto(msgpack.packb({"type": "tracker", "seq": seq, "t": 0, "pos": pos}), (host, int(port)))
                reply = msgpack.unpackb(bridge.recvfrom(2048)[0])
                assert reply["code"] == "out_of_range"
            await asyncio.sleep(1.1)  # the previous test's driver has gone quiet by now
            bridge.sendto(msgpack.packb({"type": "tracker", "seq": 9, "t": 0, "pos": SANE}), (host, int(port)))
            state = await _state_where(viewer, lambda s: s["driver"] == [source, 9])
        assert state["hip"] == SANE and _on_dome(state["proxy"])
        await viewer.close()
    run(go())


def _nested(depth: int) -> str:
    return "[" * depth + "]" * depth


BAD_JSON = [
    ('{"type":"tracker","seq":1,"t":0,"pos":' + _nested(995) + "}", "bad_message"),
    ('{"type":"tracker","seq":1,"t":0,"pos":' + _nested(20_000) + "}", "bad_message"),
    (json.dumps({"type": "tracker", "seq": 2**64, "t": 0, "pos": [0, 0, 0]}), "out_of_range"),
    ('{"type":"tracker","seq":1,"t":' + "9" * 400 + ',"pos":[0,0,0]}', "non_finite"),
    ('{"type":"tracker","seq":1,"t":0,"pos":[0,' + "9" * 400 + ',0]}', "non_finite"),
    ('{"type":"tracker","seq":1,"t":0,"pos":[0,0,0],"quat":[' + "9" * 400 + ',0,0,0]}', "non_finite"),
    ('{"type":"input","key":"a","action":"press","value":' + "9" * 400 + "}", "non_finite"),
    ('{"type":"tracker","seq":1,"t":0,"pos":[0,0,0],"extra":1e999}', "non_finite"),
    ('{"type":"input","key":"a","action":"down","pad":"' + "😀" * 65_010 + '"}', "too_large"),
]


def test_bad_frames_each_get_one_error_and_the_connection_stays_open(server):
    async def go():
        client = await Client.connect(_ws(server), "json")
        await client.recv_type("scene")
        for text, code in BAD_JSON:
            await client.ws.send(text)
            error = await _error(client)
            assert error["code"] == code, (text[:60], error)
        msgpack_client = await Client.connect(_ws(server))
        await msgpack_client.recv_type("scene")
        await msgpack_client.ws.send(b"\x84\xa4type\xa7tracker\xa3seq\x01\xa1t\x00\xa3pos" + b"\x91" * 995 + b"\x00")
        assert (await _error(msgpack_client))["code"] == "bad_message"
        # both connections are open and served; exactly one error each (none queued behind)
        for c in (client, msgpack_client):
            await c.recv_type("state")
            await c.send({"type": "tracker", "seq": 5, "t": 0, "pos": [0, 0, 1.2]})
            await c.send({"type": "teleport"})
            assert (await _error(c))["code"] == "unknown_type"
            await c.close()
    run(go())


def test_a_key_flood_is_rate_limited_and_does_not_inflate_other_viewers_frames(server):
    async def go():
        flooder = await Client.connect(_ws(server))
        viewer = await Client.connect(_ws(server), role="observer")
        await flooder.recv_type("scene")
        await viewer.recv_type("scene")
        press = msgpack.packb({"type": "input", "key": "x", "action": "press"})
        sizes, events = [], []

        async def watch():
            end = time.monotonic() + 2.0
            while time.monotonic() < end:
                data = await asyncio.wait_for(viewer.ws.recv(), 2.0)
                message = msgpack.unpackb(data)
                if message["type"] == "state":
                    sizes.append(len(data))
                    events.append(len(message["events"]))
        watcher = asyncio.create_task(watch())
        start = time.monotonic()
        sent = 0
        while time.monotonic() - start < 1.5:  # as fast as the socket takes them
            for _ in range(100):
                await flooder.ws.send(press)
            sent += 100
            await asyncio.sleep(0)
        await watcher
        errors = []
        end = time.monotonic() + 1.0  # state frames keep coming: read for a while, not until quiet
        while time.monotonic() < end:
            message = await flooder.recv()
            if message["type"] == "error":
                errors.append(message["code"])
        window_s = time.monotonic() - start  # the flood's errors can only have come within this
        await flooder.close()
        await viewer.close()
        return sent, sizes, events, errors, window_s

    sent, sizes, events, errors, window_s = run(go())
    assert sent >= 2000
    # one a second: a busy machine works through the flood for longer, but never more often than that
    assert set(errors) == {"rate_limited"} and 1 <= len(errors) <= math.floor(window_s) + 1, (errors, window_s)
    assert max(events) <= 32
    assert sum(events) <= 20 + 50 * 2.5, "only the budget reaches the loop"
    assert statistics.median(sizes) < 1500, statistics.median(sizes)
