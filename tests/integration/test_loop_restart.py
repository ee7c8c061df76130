"""A dead loop process is restarted by the hub; connected clients keep their connection; the tick
count goes on; a free trial is resumed, a recorded trial ends as interrupted and is retried."""

import asyncio
import csv
import json
import os
import signal
import sqlite3
import time

import msgpack
import websockets

from tests.integration.test_experiment_live import Api, answers_for, new_session, run_trial, touch

from tests.live_server import admin_token, get_json, start_server, stop_server


def test_killed_loop_is_restarted_and_clients_get_the_scene_again():
    proc, base = start_server("contact-angle")
    try:
        before = get_json(base + "/api/health")
        loop_pid = before["loop"]["pid"]

        async def go():
            async with websockets.connect(base.replace("http", "ws") + "/ws", subprotocols=["viestac.v1.msgpack"],
                                          max_queue=None) as ws:
                await ws.send(msgpack.packb({"type": "hello", "v": 1, "role": "observer", "client": "t",
                                             "token": admin_token(base)}))
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
        # the switch is refused (409) until a device that can show stiffness has connected: on a busy
        # machine the simulated rig's emulators may still be starting when the server answers
        deadline = time.monotonic() + 30
        while {d["status"] for d in get_json(base + "/api/devices")["devices"]} != {"connected"}:
            assert time.monotonic() < deadline, "the simulated rig's devices did not connect"
            time.sleep(0.1)
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
        # The new loop continues the tick count (it never goes back): wait for a state of the new scene hash
        # announced by the new loop, i.e. a tick well past the kill.
        while (state := get_json(base + "/api/state"))["tick"] < tick_before + 500:
            assert time.monotonic() < deadline, "no state from the restarted loop"
            time.sleep(0.05)
        assert state["values"]["right_level"] == 2 and state["values"]["middle_level"] == 7, \
            "the restarted loop resumed the production trial"
        now = get_json(base + "/api/scenario")
        assert (now["id"], now["params"]["middle_level"], now["seed"], now["trial"]) == ("stiffness-v1", 3, 4, trial)
        assert get_json(base + "/api/scene")["scene"]["name"] == "stiffness"
    finally:
        stop_server(proc)


def test_a_loop_restart_mid_trial_interrupts_the_attempt_keeps_its_rows_and_the_retry_counts(tmp_path):
    data = tmp_path / "data"
    proc, base = start_server("contact-angle", extra=["--data-dir", str(data), "--record-every", "5"])
    api = Api(base)
    try:
        session = new_session(api, "P11")
        sid, trials = session["id"], session["trials"]
        run_trial(api, sid, 0)
        api.ok("POST", f"/api/sessions/{sid}/trials/1/start")
        asyncio.run(touch(api.ws, 0.4))
        time.sleep(0.3)  # the recorder flushes every 0.25 s
        loop_pid = get_json(base + "/api/health")["loop"]["pid"]
        tick_before = get_json(base + "/api/state")["tick"]
        os.kill(loop_pid, signal.SIGKILL)
        deadline = time.monotonic() + 15
        while (view := api.ok("GET", f"/api/sessions/{sid}"))["running"] is not None:
            assert time.monotonic() < deadline, "the interrupted trial is still running"
            time.sleep(0.05)
        trial = view["trials"][1]
        assert (trial["status"], trial["reason"], trial["attempt"], view["next"]) == ("pending", "interrupted", 1, 1)
        while get_json(base + "/api/health")["loop"]["pid"] in (loop_pid, None):
            assert time.monotonic() < deadline, "the loop was not restarted"
            time.sleep(0.05)
        while (state := get_json(base + "/api/state"))["tick"] <= tick_before:
            assert time.monotonic() < deadline, "no state from the restarted loop"
            time.sleep(0.05)
        now = get_json(base + "/api/scenario")
        assert now["trial"] is None, "the restarted loop did not restart the recorded trial by itself"

        api.ok("POST", f"/api/sessions/{sid}/trials/1/start")
        time.sleep(0.3)  # long enough for rows of the retry to be recorded
        for question, value in answers_for(trials[1]).items():
            api.ok("PUT", f"/api/sessions/{sid}/trials/1/responses/{question}", {"value": value})
        retried = api.ok("POST", f"/api/sessions/{sid}/trials/1/finish")
        assert retried["status"] == "answered" and retried["attempt"] == 2
        assert 0 <= retried["started_tick"] < retried["ended_tick"], "ticks never go back"
    finally:
        stop_server(proc)

    db = sqlite3.connect(data / "viestac.sqlite")
    tid = trials[1]["id"]
    first = db.execute("SELECT COUNT(*), MIN(tick), MAX(tick), MAX(contact) FROM samples WHERE trial_id = ? "
                       "AND attempt = 1", (tid,)).fetchone()
    assert first[0] > 20 and first[3] == 1 and first[2] < state["tick"], "the attempt's rows up to the crash are kept"
    second_first_tick = db.execute("SELECT MIN(tick) FROM samples WHERE trial_id = ? AND attempt = 2",
                                   (tid,)).fetchone()[0]
    assert second_first_tick > first[2], "the retry's ticks follow the interrupted attempt's"
    events = db.execute("SELECT attempt, kind, body_json FROM events WHERE trial_id = ? AND kind IN "
                        "('interrupted', 'dropped') ORDER BY id", (tid,)).fetchall()
    assert [(a, k, json.loads(b)["reason"]) for a, k, b in events] == [(1, "interrupted", "loop restart")]
    db.close()

    out = tmp_path / "export"
    from server.experiment.export import export
    export(data / "viestac.sqlite", out, all_sessions=True)
    rows = list(csv.DictReader(next(out.rglob("trials_wide.csv")).open()))
    durations = [float(r["duration_s"]) for r in rows if r["duration_s"]]
    assert durations and min(durations) >= 0, "no negative durations"
