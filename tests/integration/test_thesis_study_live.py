"""The shipped thesis study, end to end on the real server (issue 6 acceptance): 13 participants
(WebSocket), one scripted experimenter (REST). Every session follows its participant's plan,
the vibration-mode order splits 7/6, every answer lands, the participant who really performs
the positioning and stiffness-production trials gets their metrics, and the export holds it all.

Participants other than P00 leave the scene alone (the experimenter enters answers and finishes);
P00 picks, holds and inserts every positioning object and produces every stiffness level."""

from __future__ import annotations

import asyncio
import csv
import subprocess
import sys
from pathlib import Path

import pytest

from scenarios.positioning import ITEMS
from tests.integration.test_experiment_live import STUDY, Api
from tests.integration.test_scenarios_live import HANG, hold, send_path, wait_for
from tests.integration.test_server_ws import Client
from tests.live_server import start_server, stop_server

PARTICIPANTS = 13
ITEM = {item.id: item for item in ITEMS}


def valid_answer(question: dict):
    kind = question["kind"]
    if kind == "likert":
        return int(question["high"])
    if kind == "number":
        low, high = question.get("low"), question.get("high")
        return low if low is not None else (high if high is not None else 1)
    if kind == "choice":
        return question["choices"][-1]
    return "fine"


async def position(url: str, object_id: str) -> None:
    """Pick the object, bring it to its target, hold it until GO, insert it (as a participant)."""
    item = ITEM[object_id]
    start, hole = item.start, item.hole_at
    target_z = item.hole.height + 0.3 + item.half
    at_target = (hole[0], hole[1], target_z + HANG)
    inside = (hole[0], hole[1], item.hole.height + 0.1)
    client = await Client.connect(url)
    await client.recv_type("scene")
    seq = await send_path(client, [(0.0, 0.0, 2.5), (*start, 1.2), (*start, item.half * 2 + 0.04)], step=0.05)
    await wait_for(client, lambda s, e: s["values"].get("phase") == "carry")
    seq = await send_path(client, [(*start, item.half * 2 + 0.04), (*start, 1.5), (at_target[0], at_target[1], 1.5),
                                   at_target], step=0.05, seq=seq)
    seq = await hold(client, at_target, 2.3, seq)
    await wait_for(client, lambda s, e: s["values"].get("phase") == "go")
    seq = await send_path(client, [at_target, inside], step=0.05, seq=seq)
    await wait_for(client, lambda s, e: any(x["name"] == "trial_done" for x in e))
    await send_path(client, [inside, (hole[0], hole[1], 2.5)], step=0.2, seq=seq)
    await client.close()


async def produce(api: Api) -> None:
    """Magnitude production: the experimenter starts recording ('r' is an operator command), the
    participant steps the right sphere down once, the experimenter stops recording."""
    client = await Client.connect(api.ws)
    await client.recv_type("scene")
    # read while pressing: a client that does not keep up gets only the newest state frame
    done = asyncio.create_task(wait_for(client, lambda s, e: any(x["name"] == "trial_done" for x in e)))
    await asyncio.to_thread(api.ok, "POST", "/api/command", {"key": "r"})
    await asyncio.sleep(0.05)
    await client.send({"type": "input", "key": "ArrowDown", "action": "down"})
    await client.send({"type": "input", "key": "ArrowDown", "action": "up"})
    await asyncio.sleep(0.05)
    await asyncio.to_thread(api.ok, "POST", "/api/command", {"key": "r"})
    await done
    await client.close()


@pytest.mark.slow
def test_the_thesis_study_runs_end_to_end_for_13_participants(tmp_path):
    data = tmp_path / "data"
    proc, base = start_server("contact-angle", extra=["--data-dir", str(data)])
    api = Api(base)
    try:
        study = api.ok("GET", f"/api/studies/{STUDY}")
        questions = {(t["id"], q["id"]): q for t in study["tasks"] for q in t["questions"] + t["end_questions"]}
        assert study["participants"] == PARTICIPANTS
        sessions = []
        for i in range(PARTICIPANTS):
            session = api.ok("POST", "/api/sessions", {"study": STUDY, "participant": f"P{i:02d}",
                                                       "experimenter": "alice", "device": "both"})
            assert session["participant_index"] == i
            api.token = session["token"]
            plan = api.ok("GET", f"/api/studies/{STUDY}/plan?participant_index={i}")
            assert [(t["task"], t["kind"], t["params"]) for t in session["trials"]] == \
                [(p["task"], p["kind"], p["params"]) for p in plan], "the session follows its participant's plan"
            for trial in session["trials"]:
                seq = trial["seq"]
                api.ok("POST", f"/api/sessions/{session['id']}/trials/{seq}/start")
                if i == 0 and trial["scenario"] == "positioning-v1" and trial["kind"] in ("trial", "main"):
                    asyncio.run(position(api.ws, trial["params"]["object"]))
                if i == 0 and trial["params"].get("mode") == "production":
                    asyncio.run(produce(api))
                for q in trial["questions"]:
                    value = valid_answer(questions[(trial["task"], q)])
                    api.ok("PUT", f"/api/sessions/{session['id']}/trials/{seq}/responses/{q}", {"value": value})
                api.ok("POST", f"/api/sessions/{session['id']}/trials/{seq}/finish")
            sessions.append(api.ok("GET", f"/api/sessions/{session['id']}"))
    finally:
        stop_server(proc)

    # every trial answered, with every answer; P00's performed trials carry their metrics
    for session in sessions:
        assert session["status"] == "completed" and session["next"] is None
        for t in session["trials"]:
            assert t["status"] == "answered" and set(t["responses"]) == set(t["questions"]), t
    performed = [t for t in sessions[0]["trials"] if t["scenario"] == "positioning-v1" and t["kind"] != "training"
                 and t["kind"] != "questionnaire"]
    assert performed and all(t["metrics"].get("completion_s", 0) > 2.0 and t["metrics"]["path_length"] > 0
                             for t in performed), [t["metrics"] for t in performed]
    productions = [t for t in sessions[0]["trials"] if t["params"].get("mode") == "production"]
    assert all(t["metrics"]["produced_level"] == 9 and t["metrics"]["target_level"] == t["params"]["level"]
               for t in productions)

    # the two vibration-mode orders split 7/6 across the 13 participants
    firsts = [next(t["task"] for t in s["trials"] if t["task"].startswith("mode_")) for s in sessions]
    assert sorted([firsts.count(f) for f in set(firsts)]) == [6, 7], firsts

    # the export holds every answer and metric
    out = tmp_path / "export"
    done = subprocess.run([sys.executable, "-m", "server.cli", "export", "--all", "--out", str(out),
                           "--data-dir", str(data)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    with (out / "all_trials_wide.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == sum(len(s["trials"]) for s in sessions)
    by_key = {(r["participant"], int(r["seq"])): r for r in rows}
    for session in sessions:
        for t in session["trials"]:
            row = by_key[(session["participant"], t["seq"])]
            for q, value in t["responses"].items():
                assert row[f"response.{q}"] == str(value), (q, value, row[f"response.{q}"])
            for name, value in t["metrics"].items():
                assert row[f"metric.{name}"] == str(value), (name, value)
    long_rows = list(csv.DictReader((next(Path(out).glob("*P00*")) / "responses_long.csv").open()))
    assert len(long_rows) == sum(len(t["responses"]) for t in sessions[0]["trials"])
