"""The hub's asyncio shell with in-memory sockets (no server): it forwards what the sessions decide
to the loop, reports refusals back, tells the loop when a tracker's client leaves, and fans the
loop's scene and state records out in the order the protocol promises."""

from __future__ import annotations

import asyncio
import json

import msgpack

from server.hub.hub import Hub
from tests.hub.access_fakes import FakeAccess, with_token
from server.ipc.records import SceneAnnounce, TrackerGone
from tests.ipc import loop_state
from tests.ipc import sent


class FakeSocket:
    """What Fanout.serve uses of a starlette WebSocket; the test plays the client. Its hello carries
    the admin's token (tests/hub/access_fakes.py); `lease` messages are kept apart in `leases`
    (tests/hub/test_hub_access.py looks at them), everything else in `got`."""

    def __init__(self, fmt: str = "msgpack"):
        self.fmt = fmt
        self.scope = {"subprotocols": [f"viestac.v1.{fmt}"], "client": ("127.0.0.1", 50000)}
        self.inbox: asyncio.Queue = asyncio.Queue()
        self.got: list[dict] = []
        self.leases: list[dict] = []
        self.close_code: int | None = None

    async def accept(self, subprotocol=None) -> None:
        assert subprotocol == f"viestac.v1.{self.fmt}"

    async def receive(self) -> dict:
        return await self.inbox.get()

    async def send_bytes(self, data: bytes) -> None:
        self._got(msgpack.unpackb(data))

    async def send_text(self, data: str) -> None:
        self._got(json.loads(data))

    def _got(self, message: dict) -> None:
        (self.leases if message["type"] == "lease" else self.got).append(message)

    async def close(self, code: int = 1000) -> None:
        self.close_code = code

    def send(self, message: dict) -> None:
        if message["type"] == "hello" and "token" not in message:
            message = with_token(message)
        if self.fmt == "msgpack":
            self.inbox.put_nowait({"type": "websocket.receive", "bytes": msgpack.packb(message)})
        else:
            self.inbox.put_nowait({"type": "websocket.receive", "text": json.dumps(message)})

    def leave(self) -> None:
        self.inbox.put_nowait({"type": "websocket.disconnect"})

    def types(self) -> list[str]:
        return [m["type"] for m in self.got]


def state_record(tick: int, scene: str) -> dict:
    """A loop state record; the loop names the scene it simulated."""
    return {"frame": tick, "tick": tick, "t": tick / 1000, "scene": scene, "hip": [0, 0, 0], "proxy": [0, 0, 0], "force": [0, 0, 0],
            "contact": False, "contacts": [], "objects": [], "cues": [], "hud": "", "values": {}, "samples": b"",
            "trackers": []}


def new_hub(accept: bool = True) -> tuple[Hub, list]:
    to_loop: list = []
    hub = Hub(server_name="test", tick_hz=1000, state_hz=60, access=FakeAccess(),  # the admin holds the lease
              send_to_loop=lambda record: to_loop.append(record) or accept)
    return hub, to_loop


async def settle() -> None:
    for _ in range(20):
        await asyncio.sleep(0)


def test_trackers_reach_the_loop_and_their_client_leaving_is_announced():
    async def go():
        hub, to_loop = new_hub()
        driver, watcher = FakeSocket(), FakeSocket("json")
        serving = [asyncio.create_task(hub.fanout.serve(ws)) for ws in (driver, watcher)]
        driver.send({"type": "hello", "v": 1, "role": "participant", "client": "t"})
        watcher.send({"type": "hello", "v": 1, "role": "observer", "client": "t"})
        driver.send({"type": "tracker", "seq": 3, "t": 1.0, "pos": [0, 0.1, 0.2]})
        await settle()
        driver_id = driver.got[0]["client_id"]
        assert [r[:3] for r in map(sent, to_loop)] == [["tracker", driver_id, 3]]
        watcher.leave()
        driver.leave()
        await asyncio.gather(*serving)
        assert to_loop[1:] == [TrackerGone(driver_id)]  # the observer sent no samples: nothing for it
        assert hub.fanout.clients() == []

    asyncio.run(go())


def test_tracker_gone_refused_by_a_full_mailbox_is_retried_until_it_arrives():
    async def go():
        accept, to_loop = [True], []
        hub = Hub(server_name="test", tick_hz=1000, state_hz=60, access=FakeAccess(),
                  send_to_loop=lambda record: (to_loop.append(record) if accept[0] else None) or accept[0])
        driver = FakeSocket()
        serving = asyncio.create_task(hub.fanout.serve(driver))
        driver.send({"type": "hello", "v": 1, "role": "participant", "client": "t"})
        driver.send({"type": "tracker", "seq": 3, "t": 1.0, "pos": [0, 0.1, 0.2]})
        await settle()
        driver_id = driver.got[0]["client_id"]
        accept[0] = False  # the loop's mailbox is full when the driver leaves
        driver.leave()
        await serving
        hub.link.retry_undelivered()
        assert [r[0] for r in map(sent, to_loop)] == ["tracker"] and list(hub.link.undelivered) == [TrackerGone(driver_id)]
        accept[0] = True
        hub.link.retry_undelivered()
        assert to_loop[-1] == TrackerGone(driver_id) and not hub.link.undelivered

    asyncio.run(go())


def test_a_full_mailbox_is_reported_to_the_client():
    async def go():
        hub, _ = new_hub(accept=False)
        ws = FakeSocket()
        serving = asyncio.create_task(hub.fanout.serve(ws))
        ws.send({"type": "hello", "v": 1, "role": "participant", "client": "t"})
        ws.send({"type": "tracker", "seq": 3, "t": 1.0, "pos": [0, 0.1, 0.2]})
        ws.send({"type": "input", "key": "r", "action": "press"})
        await settle()
        assert [m.get("code") for m in ws.got] == [None, "busy", "busy"]
        ws.leave()
        await serving

    asyncio.run(go())


def test_an_unsupported_version_is_answered_then_closed():
    async def go():
        hub, _ = new_hub()
        ws = FakeSocket()
        serving = asyncio.create_task(hub.fanout.serve(ws))
        ws.send({"type": "hello", "v": 9, "role": "participant", "client": "t"})
        await asyncio.wait_for(serving, 2.0)  # serve returns once the sender closed
        assert ws.types() == ["error"] and ws.got[0]["code"] == "unsupported_version" and ws.close_code == 1002

    asyncio.run(go())


def test_a_state_of_the_old_scene_read_together_with_the_new_scene_is_not_sent_after_it():
    """The loop's reader hands the hub several records at once: the last state of scene A, then
    scene B. The broadcast of the A state runs after both; the client gets scene B first (control
    goes first), so that state must not follow it."""
    async def go():
        hub, _ = new_hub()
        sockets = [FakeSocket(("msgpack", "json")[i % 2]) for i in range(10)]  # more than one slice
        serving = [asyncio.create_task(hub.fanout.serve(ws)) for ws in sockets]
        hub.link.on_loop_record(SceneAnnounce({"name": "a"}, "aaaa"))
        for ws in sockets:
            ws.send({"type": "hello", "v": 1, "role": "observer", "client": "t"})
        await settle()
        hub.link.on_loop_record(loop_state(state_record(1, "aaaa")))
        hub.link.on_loop_record(SceneAnnounce({"name": "b"}, "bbbb"))  # in the same reader callback
        await settle()
        hub.link.on_loop_record(loop_state(state_record(2, "bbbb")))
        await settle()
        for ws in sockets:
            seen = [(m["type"], m.get("hash") or m.get("scene")) for m in ws.got]
            assert seen == [("welcome", None), ("scene", "aaaa"), ("scene", "bbbb"), ("state", "bbbb")], seen
            ws.leave()
        await asyncio.gather(*serving)

    asyncio.run(go())
