"""The hub's access-control wiring with in-memory sockets: the lease reaches every client and a
driver that loses it leaves the HIP, lease changes from a worker thread land on the event loop,
one token's connections are capped, experimenter commands need the lease, a hub without access
control admits nobody."""

from __future__ import annotations

import asyncio
import threading

from server.hub import fanout as fanout_module
from server.hub.hub import Hub
from tests.hub.access_fakes import EXP_A, SECRET
from tests.hub.test_hub_shell import FakeSocket, new_hub, settle
from tests.ipc import sent

TRACKER = {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 1]}


def test_a_hub_without_access_control_admits_nobody():
    async def go():
        hub = Hub(server_name="test", tick_hz=1000, state_hz=60)
        ws = FakeSocket()
        serving = asyncio.create_task(hub.fanout.serve(ws))
        ws.send({"type": "hello", "v": 1, "role": "observer", "client": "t"})
        await asyncio.wait_for(serving, 3)
        assert [m.get("code") for m in ws.got] == ["unauthorized"] and ws.close_code == 1008

    asyncio.run(go())


def test_the_lease_reaches_every_client_and_a_driver_that_loses_it_leaves_the_hip():
    async def go():
        hub, to_loop = new_hub()
        access = hub.fanout.access
        hub.owner.bind()
        driver, watcher = FakeSocket(), FakeSocket("json")
        serving = [asyncio.create_task(hub.fanout.serve(ws)) for ws in (driver, watcher)]
        driver.send({"type": "hello", "v": 1, "role": "participant", "client": "t"})
        watcher.send({"type": "hello", "v": 1, "role": "observer", "client": "t"})
        driver.send(TRACKER)
        await settle()
        assert [r[0] for r in map(sent, to_loop)] == ["tracker"]
        assert [len(ws.leases) for ws in (driver, watcher)] == [1, 1]  # after the welcome
        assert driver.leases[0]["holder"]["role"] == "admin"
        # the holder releases it from a REST worker thread: the change lands on the event loop
        worker = threading.Thread(target=lambda: (access.lease.release(access.lease.holder), access.lease_changed()))
        worker.start()
        worker.join()
        await settle()
        assert [r[0] for r in map(sent, to_loop)] == ["tracker", "tracker_gone"]
        assert driver.leases[-1]["holder"] is None and watcher.leases[-1]["holder"] is None
        driver.send(TRACKER)
        await settle()
        assert driver.got[-1]["code"] == "forbidden" and [r[0] for r in map(sent, to_loop)] == ["tracker", "tracker_gone"]
        for ws in (driver, watcher):
            ws.leave()
        await asyncio.gather(*serving)

    asyncio.run(go())


def test_experimenter_commands_need_the_lease(monkeypatch):
    async def go():
        hub, to_loop = new_hub()
        monkeypatch.setattr(hub.control, "is_operator_command", lambda key: key == "tap_angle")
        holder, other = FakeSocket(), FakeSocket()
        serving = [asyncio.create_task(hub.fanout.serve(ws)) for ws in (holder, other)]
        holder.send({"type": "hello", "v": 1, "role": "operator", "client": "t"})
        other.send({"type": "hello", "v": 1, "role": "operator", "client": "t", "token": SECRET[EXP_A.token_id]})
        await settle()
        other.send({"type": "input", "key": "tap_angle", "action": "press"})
        await settle()
        assert other.got[-1]["code"] == "forbidden" and "lease" in other.got[-1]["message"] and to_loop == []
        holder.send({"type": "input", "key": "tap_angle", "action": "press"})
        await settle()
        assert [r[:3] for r in map(sent, to_loop)] == [["input", 1, "tap_angle"]]
        for ws in (holder, other):
            ws.leave()
        await asyncio.gather(*serving)

    asyncio.run(go())


def test_one_token_has_at_most_the_cap_of_connections(monkeypatch):
    monkeypatch.setattr(fanout_module, "MAX_CONNECTIONS_PER_TOKEN", 3)

    async def go():
        hub, _ = new_hub()
        sockets = [FakeSocket() for _ in range(4)]
        serving = []
        for ws in sockets:
            serving.append(asyncio.create_task(hub.fanout.serve(ws)))
            ws.send({"type": "hello", "v": 1, "role": "observer", "client": "t"})
            await settle()
        assert [ws.got[0]["type"] for ws in sockets[:3]] == ["welcome"] * 3
        assert [m.get("code") for m in sockets[3].got] == ["rate_limited"] and sockets[3].close_code == 1008
        sockets[0].leave()
        await settle()
        again = FakeSocket()
        serving.append(asyncio.create_task(hub.fanout.serve(again)))
        again.send({"type": "hello", "v": 1, "role": "observer", "client": "t"})
        await settle()
        assert again.got[0]["type"] == "welcome"  # a closed connection frees its place
        for ws in sockets[1:3] + [again]:
            ws.leave()
        await asyncio.gather(*serving)

    asyncio.run(go())
