"""A broadcast serves participants and operators before observers, whatever order they joined in
(docs/performance.md, "Tracker → state round trip": a participant served after 64 viewers saw its
own hand's frame 1-2 ms later)."""

from __future__ import annotations

import asyncio

from server.hub.hub import ClientSession, Hub


class RecordingSocket:
    def __init__(self, client_id: int, sent: list[int]):
        self.client_id, self.sent = client_id, sent

    async def send_bytes(self, data: bytes) -> None:
        self.sent.append(self.client_id)


def test_a_broadcast_sends_to_participants_and_operators_before_the_observers_who_joined_earlier():
    async def scenario() -> list[int]:
        hub = Hub(server_name="test", tick_hz=1000, state_hz=60)
        sent: list[int] = []
        roles = ["observer"] * 20 + ["participant"] + ["observer"] * 5 + ["operator"]
        for client_id, role in enumerate(roles, start=1):
            s = ClientSession(client_id, RecordingSocket(client_id, sent), "msgpack")
            s.role, s.welcomed = role, True
            hub.sessions[client_id] = s
        senders = [asyncio.create_task(hub._sender(s)) for s in hub.sessions.values()]
        await asyncio.sleep(0)  # every sender waits for its wake-up, as between frames
        hub._frames, hub._frame_seq = {"msgpack": b"frame"}, 1
        await hub._broadcast()
        while len(sent) < len(roles):
            await asyncio.sleep(0)
        for task in senders:
            task.cancel()
        return sent

    sent = asyncio.run(scenario())
    assert sent[:2] == [21, 27], "the participant, then the operator, each before any observer"
    assert sorted(sent[2:]) == [i for i in range(1, 27) if i != 21], "every observer still gets the frame"
    assert sent[2:] == sorted(sent[2:]), "observers in the order they joined"
