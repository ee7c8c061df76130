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


def test_a_restarted_loop_resumes_the_switched_scenario_and_its_trial():
    proc, base = start_server("contact-angle")
    try:
        get_json(base + "/api/scenario", "POST", body={"name": "stiffness", "params": {"middle_level": 3}, "seed": 4})
        trial = {"phase": "main", "params": {"mode": "production", "level": 7, "start_level": 2}, "index": 5}
        deadline = time.monotonic() + 5
        while get_json(base + "/api/scenario").get("id") != "stiffness-v1":
            assert time.monotonic() < deadline
            time.sleep(0.05)
        get_json(base + "/api/trial", "POST", body=trial)
        while get_json(base + "/api/scenario").get("trial") != trial:
            assert time.monotonic() < deadline
            time.sleep(0.05)
        time.sleep(1.0)
        loop_pid = get_json(base + "/api/health")["loop"]["pid"]
        tick_before = get_json(base + "/api/state")["tick"]
        os.kill(loop_pid, signal.SIGKILL)
        deadline = time.monotonic() + 15
        while get_json(base + "/api/health")["loop"]["pid"] in (loop_pid, None):
            assert time.monotonic() < deadline, "the loop was not restarted"
            time.sleep(0.1)
        while (state := get_json(base + "/api/state"))["tick"] >= tick_before:  # the new loop counts from 0
            assert time.monotonic() < deadline, "no state from the restarted loop"
            time.sleep(0.05)
        assert state["values"]["right_level"] == 2 and state["values"]["middle_level"] == 7, \
            "the restarted loop resumed the production trial"
        now = get_json(base + "/api/scenario")
        assert (now["id"], now["params"]["middle_level"], now["seed"], now["trial"]) == ("stiffness-v1", 3, 4, trial)
        assert get_json(base + "/api/scene")["scene"]["name"] == "stiffness"
    finally:
        stop_server(proc)
