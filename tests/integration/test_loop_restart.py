"""A dead loop process is restarted by the hub; connected clients keep their connection."""

import asyncio
import os
import signal
import time

import msgpack
import websockets

from server.bench.loop_bench import get_json, start_server, stop_server


def test_killed_loop_is_restarted_and_clients_get_the_scene_again():
    proc, base = start_server("contact-angle")
    try:
        before = get_json(base + "/api/health")
        loop_pid = before["loop"]["pid"]

        async def go():
            async with websockets.connect(base.replace("http", "ws") + "/ws", subprotocols=["viestac.v1.msgpack"],
                                          max_queue=None) as ws:
                await ws.send(msgpack.packb({"type": "hello", "v": 1, "role": "observer", "client": "t"}))
                kinds = []
                while "state" not in kinds:
                    kinds.append(msgpack.unpackb(await ws.recv())["type"])
                os.kill(loop_pid, signal.SIGKILL)
                deadline = time.monotonic() + 15
                scenes_after_kill = 0
                states_after_scene = 0
                while time.monotonic() < deadline and states_after_scene < 10:
                    kind = msgpack.unpackb(await asyncio.wait_for(ws.recv(), 15))["type"]
                    scenes_after_kill += kind == "scene"
                    states_after_scene += kind == "state" and scenes_after_kill > 0
                return kinds, scenes_after_kill, states_after_scene

        kinds, scenes_after_kill, states_after_scene = asyncio.run(go())
        assert kinds[:2] == ["welcome", "scene"]
        assert scenes_after_kill == 1 and states_after_scene == 10
        after = get_json(base + "/api/health")
        assert after["loop"]["alive"] and after["loop"]["restarts"] == 1
        assert after["loop"]["pid"] != loop_pid
    finally:
        stop_server(proc)
