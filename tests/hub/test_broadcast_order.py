"""A broadcast serves participants and operators before observers, whatever order they joined in
(docs/performance.md, "Tracker → state round trip (/ws)": a participant served after 64 viewers
saw its own hand's frame 1-2 ms later)."""

from __future__ import annotations

import asyncio

import msgpack

from server.hub.hub import Hub
from tests.hub.access_fakes import FakeAccess
from tests.hub.test_hub_shell import FakeSocket, settle, state_record
from server.ipc.records import SceneAnnounce
from tests.ipc import loop_state


class OrderedSocket(FakeSocket):
    """Notes, in one list shared by every client, who was sent a state frame when."""

    def __init__(self, name: int, order: list[int]):
        super().__init__("msgpack")
        self.name, self.order = name, order

    async def send_bytes(self, data: bytes) -> None:
        await super().send_bytes(data)
        if msgpack.unpackb(data)["type"] == "state":
            self.order.append(self.name)


def test_a_broadcast_sends_to_participants_and_operators_before_the_observers_who_joined_earlier():
    roles = ["observer"] * 20 + ["participant"] + ["observer"] * 5 + ["operator"]

    async def go() -> list[int]:
        hub = Hub(server_name="test", tick_hz=1000, state_hz=60, access=FakeAccess(), send_to_loop=lambda record: True)
        order: list[int] = []
        sockets = [OrderedSocket(n, order) for n in range(1, len(roles) + 1)]
        serving = []
        for ws, role in zip(sockets, roles):  # they join in this order
            serving.append(asyncio.create_task(hub.fanout.serve(ws)))
            ws.send({"type": "hello", "v": 1, "role": role, "client": "t"})
            await settle()
        hub.link.on_loop_record(SceneAnnounce({"name": "a"}, "aaaa"))
        await settle()
        hub.link.on_loop_record(loop_state(state_record(1, "aaaa")))
        for _ in range(10):
            await settle()
        for ws in sockets:
            ws.leave()
        await asyncio.gather(*serving)
        return order

    order = asyncio.run(go())
    assert order[:2] == [21, 27], "the participant, then the operator, each before any observer"
    assert sorted(order[2:]) == [i for i in range(1, 27) if i != 21], "every observer still gets the frame"
    assert order[2:] == sorted(order[2:]), "observers in the order they joined"
