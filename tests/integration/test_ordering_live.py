"""Ordering on the real server (docs/protocol.md): every state after `scene` H names H until the
next `scene`. Scenario switches in quick succession while a participant streams trackers, watched
by clients of both formats: no client may see a state naming another scene than the last scene
it received (the hub's per-client sender sends control messages before the latest state, so a
frame of the old scene waiting in the latest-wins slot used to follow the new scene). With more
clients than one broadcast slice (8) the hub yields in the middle of a broadcast, which widens
that window: the hub before issue 17 sent ~300 such states to 32 clients in 200 switches."""

from __future__ import annotations

import asyncio
import time

import pytest

from tests.live_server import get_json, start_server, stop_server
from tests.integration.test_server_ws import Client

SWITCHES = 200
SCENARIOS = ("stiffness", "contact-angle")


class Watch:
    """What one client saw: its last scene, and every state that named another."""

    def __init__(self):
        self.scene: str | None = None
        self.scenes = 0
        self.states = 0
        self.states_since_scene = 0
        self.wrong: list[tuple[str | None, str]] = []


async def _read(client: Client, watch: Watch) -> None:
    while True:
        message = await client.recv(timeout=10.0)
        if message["type"] == "scene":
            watch.scene, watch.scenes, watch.states_since_scene = message["hash"], watch.scenes + 1, 0
        elif message["type"] == "state":
            watch.states += 1
            watch.states_since_scene += 1
            if message["scene"] != watch.scene:
                watch.wrong.append((watch.scene, message["scene"]))


async def _stream(client: Client) -> None:
    seq = 0
    while True:  # in and out of the contact-angle dome: contacts and cue changes, extra state frames
        depth = 0.45 if seq % 20 < 10 else 0.8
        await client.send({"type": "tracker", "seq": seq, "t": time.time() * 1e3, "pos": [0.0, 0.3, depth]})
        seq += 1
        await asyncio.sleep(0.005)


async def _until(condition, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, what
        await asyncio.sleep(0.002)


async def _switch_while_watching(base: str, n_clients: int) -> list[Watch]:
    """`n_clients` of both formats, the last one a participant streaming trackers."""
    url = base.replace("http://", "ws://") + "/ws"
    clients = [await Client.connect(url, ("msgpack", "json")[i % 2], role="observer") for i in range(n_clients - 1)]
    clients.append(await Client.connect(url, "json", role="participant"))
    watches = [Watch() for _ in clients]
    tasks = [asyncio.create_task(_read(c, w)) for c, w in zip(clients, watches)]
    tasks.append(asyncio.create_task(_stream(clients[-1])))
    try:
        await _until(lambda: all(w.scenes for w in watches), 5.0, "every client gets the first scene")
        for k in range(SWITCHES):
            body = {"name": SCENARIOS[k % 2], "force": True}
            await asyncio.to_thread(get_json, base + "/api/scenario", "POST", body=body)
            await _until(lambda n=k + 2: all(w.scenes >= n for w in watches), 5.0,  # the first, then one a switch
                         f"switch {k}: the scene reaches all")
            for task in tasks:
                if task.done():
                    task.result()  # a reader that failed (closed connection, timeout) fails the test here
        await _until(lambda: all(w.states_since_scene for w in watches), 5.0, "states of the last scene flow")
    finally:
        for task in tasks:
            task.cancel()
        for client in clients:
            await client.close()
    return watches


@pytest.fixture(scope="module")
def server():
    proc, base = start_server("contact-angle")
    yield base
    stop_server(proc)


@pytest.mark.parametrize("n_clients", [4, 32])
def test_no_state_names_an_older_scene_than_the_last_scene_received(server, n_clients):
    watches = asyncio.run(_switch_while_watching(server, n_clients))
    for i, watch in enumerate(watches):
        assert watch.scenes == SWITCHES + 1, f"client {i}: {watch.scenes} scenes"
        assert not watch.wrong, (f"client {i}: {len(watch.wrong)} of {watch.states} states named another scene "
                                 f"than the last one received, e.g. {watch.wrong[:3]}")
