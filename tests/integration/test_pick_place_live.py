"""Pick and place through the real server with two fingers on two devices: the FerroVibe on the
index, the FingerTac on the thumb (`serve --finger`), one /ws client sending both fingertips in
one tracker message (`pos` the index, `points` the thumb). Each device vibrates with its own
finger's contact; the grasp, the carry and the placement run in the loop process."""

from __future__ import annotations

import asyncio
import time

import pytest

from scenarios.pick_place import BLOCK_SIDE, BLOCK_START, THUMB
from tests.live_server import start_server, stop_server
from tests.integration.test_scenarios_live import Server, now_us
from tests.integration.test_server_ws import Client

HALF = BLOCK_SIDE / 2
TOUCH = HALF + 0.06  # a fingertip centre resting on a side face
CENTRE = (*BLOCK_START, HALF)
AWAY = [(0.0, 1.6, 1.5), (0.0, 0.3, 1.5)]  # both fingers in the air, far from the block


@pytest.fixture(scope="module")
def server():
    proc, base = start_server("pick-place", extra=["--rig", "fingertac,ferrovibe",
                                                   "--finger", "ferrovibe=right.index.tip",
                                                   "--finger", "fingertac=right.thumb.tip"])
    try:
        yield Server(base)
    finally:
        stop_server(proc)


def pinch(centre, gap):
    x, y, z = centre
    return [x, y + TOUCH + gap, z], [x, y - TOUCH - gap, z]


async def stream(client, frames, seq=0, rate_hz=200.0):
    """Send (index, thumb) frames at `rate_hz`; returns the next seq."""
    for index, thumb in frames:
        await client.send({"type": "tracker", "seq": seq, "t": time.time() * 1e3, "pos": list(index),
                           "points": {THUMB: list(thumb)}})
        seq += 1
        await asyncio.sleep(1 / rate_hz)
    return seq


async def newest_state(client, settle_s=0.2) -> dict:
    state = await client.recv_type("state")
    end = time.monotonic() + settle_s
    while time.monotonic() < end:
        state = await client.recv_type("state")
    return state


def vibrating(rows) -> bool:
    return any(r["mode"] == "continuous" and r["gate"] == "1" for r in rows)


def run(server, frames) -> dict:
    async def go():
        client = await Client.connect(server.ws)
        await client.recv_type("scene")
        await stream(client, frames)
        state = await newest_state(client)
        await client.close()
        return state
    return asyncio.run(go())


def test_the_index_alone_on_the_block_vibrates_the_index_device_only(server):
    run(server, [AWAY] * 20)
    t0 = now_us()
    far_thumb = AWAY[1]
    frames = [(pinch(CENTRE, 0.1 - 0.11 * k / 40)[0], far_thumb) for k in range(41)] + \
             [(pinch(CENTRE, -0.01)[0], far_thumb)] * 80
    state = run(server, frames)
    index, thumb = state["tools"]
    assert index["contact"] and not thumb["contact"] and state["values"]["phase"] == "idle"
    assert vibrating(server.timeline("ferrovibe", t0, vibrating)), "the index's device vibrates"
    assert not vibrating(server.timeline("fingertac", t0, timeout_s=0.6)), "the thumb's device stays still"
    run(server, [AWAY] * 20)


def test_grasp_carry_and_place_through_the_server_with_both_devices(server):
    run(server, [AWAY] * 20)
    t0 = now_us()
    closing = [pinch(CENTRE, 0.1 - 0.13 * k / 40) for k in range(41)] + [pinch(CENTRE, -0.03)] * 40
    target = (0.0, -0.9, HALF + 0.02)
    carry = [pinch(tuple(a + (b - a) * k / 150 for a, b in zip(CENTRE, target)), -0.03) for k in range(1, 151)]
    held = run(server, closing + carry)
    assert held["values"]["phase"] == "held", held["values"]
    assert [t["name"] for t in held["tools"]] == ["right.index.tip", THUMB]
    assert all(t["contact"] for t in held["tools"])
    assert vibrating(server.timeline("ferrovibe", t0, vibrating))
    assert vibrating(server.timeline("fingertac", t0, vibrating)), "the thumb's device vibrates with the grip"
    opening = [pinch(target, -0.03 + 0.13 * k / 30) for k in range(1, 31)]
    placed = run(server, opening + [AWAY] * 20)
    assert placed["values"]["phase"] == "placed" and placed["values"]["placement_error"] < 0.02
    assert placed["cues"] == []
    run(server, [AWAY] * 5)
