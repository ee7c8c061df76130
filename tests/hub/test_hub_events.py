"""The hub offers each client only its newest state frame: state records that arrive while a
broadcast is pending are never offered on their own. Their events still reach every client, once
each and in order, with the frame it is sent (server/hub/event_log.py)."""

import asyncio

from server.hub.hub import Hub
from server.hub.session import ServerInfo, Session
from server.wire import codec
from tests.hub.access_fakes import gate, with_token
from tests.ipc import loop_state


def record(tick: int, events: list) -> dict:
    return {"frame": tick, "tick": tick, "t": 0.0, "scene": "s", "hip": [0, 0, 0], "proxy": [0, 0, 0],
            "force": [0, 0, 0], "contact": False, "contacts": [], "objects": [], "cues": [], "hud": "",
            "values": {}, "samples": b"", "trackers": [], "events": events}


def test_records_the_hub_never_offered_on_their_own_still_give_their_events():
    async def go():
        hub = Hub(server_name="test", tick_hz=1000, state_hz=60)
        sessions = []
        for client_id, fmt in ((1, "json"), (2, "msgpack")):
            session = Session(client_id, fmt, ServerInfo("t", 1000, 60.0), 0, gate=gate()[0], events=hub.fanout.event_log)
            session.set_scene("s", {f: codec.encode({"type": "scene", "v": 1, "hash": "s", "scene": {}}, f)
                                    for f in codec.FORMATS})
            session.receive(codec.encode(with_token({"type": "hello", "v": 1, "role": "observer"}), fmt), 1)

            class Conn:
                wake = asyncio.Event()
            Conn.session = session
            hub.fanout.connections[client_id] = Conn
            sessions.append(session)

        def taken(session) -> list[dict]:
            out = []
            while (frame := session.outbox.next_frame()) is not None:
                out.append(codec.decode(frame, session.fmt))
            return [m for m in out if m["type"] == "state"]

        tap, release, go_ = ({"tick": t, "t": t / 1000, "name": n} for t, n in ((2, "tap"), (3, "release"), (5, "go")))
        hub.link.on_loop_record(loop_state(record(1, [])))
        await asyncio.sleep(0)  # the broadcast runs: every client is offered frame 1
        assert [[m["tick"] for m in taken(s)] for s in sessions] == [[1], [1]]
        for tick, events in ((2, [tap]), (3, [release]), (4, []), (5, [go_])):
            hub.link.on_loop_record(loop_state(record(tick, events)))  # faster than the hub broadcasts
        await asyncio.sleep(0)
        for session in sessions:
            got = taken(session)
            assert [m["tick"] for m in got] == [5], "only the newest frame is offered"
            assert got[0]["events"] == [tap, release, go_]
        hub.link.on_loop_record(loop_state(record(6, [])))
        await asyncio.sleep(0.05)  # two frames went just now: the frame ceiling's next slot (frame_ceiling.py)
        assert [[m["events"] for m in taken(s)] for s in sessions] == [[[]], [[]]], "each event once"

    asyncio.run(go())
