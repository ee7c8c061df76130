"""A participant-paced task on the real server, over /ws alone after the console's first start: each
answer finishes its trial and the next starts after the inter-trial interval, a break waits for the
participant's "continue", REST pause holds and resume goes on, the task's end waits for the
experimenter, and the console's session view shows the pacing state."""

from __future__ import annotations

import asyncio
import time

import pytest

from tests.integration.test_experiment_live import Api
from tests.integration.test_participant_answers_live import next_ask, next_error, participant_token
from tests.integration.test_server_ws import Client
from tests.live_server import start_server, stop_server

STUDY = """
id = "paced-live"
title = "Paced"
seed = 2
participants = 1

[[tasks]]
id = "pick"
scenario = "contact-angle"
conditions = [{ angle_deg = 10 }, { angle_deg = 20 }, { angle_deg = 30 }, { angle_deg = 40 }]
order = "fixed"

[tasks.pacing]
by = "participant"
iti_ms = 300
break_every = 2

[[tasks.questions]]
id = "which"
kind = "choice"
text = "Which?"
choices = ["1", "2"]
answered_by = "participant"

[[tasks.end_questions]]
id = "effort"
kind = "likert"
text = "How hard was it?"
"""


@pytest.fixture
def server(tmp_path):
    studies = tmp_path / "studies"
    studies.mkdir()
    (studies / "paced-live.toml").write_text(STUDY, encoding="utf-8")
    proc, base = start_server("contact-angle", extra=["--data-dir", str(tmp_path / "data"), "--studies", str(studies),
                                                      "--force"])
    yield Api(base)
    stop_server(proc)


async def ask_where(client: Client, want, timeout: float = 5.0) -> dict:
    """The next `ask` for which `want(ask)` holds."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout
    while True:
        m = await next_ask(client, timeout=max(0.1, deadline - loop.time()))
        if want(m):
            return m


def statuses(api: Api, sid: str) -> list[str]:
    return [t["status"] for t in api.ok("GET", f"/api/sessions/{sid}")["trials"]]


def test_a_paced_task_runs_from_the_participants_answers(server):
    api = server
    session = api.ok("POST", "/api/sessions", {"study": "paced-live", "participant": "P01", "experimenter": "alice"})
    api.token, sid = session["token"], session["id"]
    mine = participant_token(api.base, sid)

    async def go():
        page = await Client.connect(api.ws, token=mine)
        await asyncio.to_thread(api.ok, "POST", f"/api/sessions/{sid}/trials/0/start")  # the console starts the task
        a = await ask_where(page, lambda m: m["seq"] == 0 and (m["pacing"] or {}).get("state") == "trial")
        assert a["pacing"] == {"state": "trial", "done": 0, "total": 4, "feedback": None}

        await page.send({"type": "answer", "seq": 0, "question": "which", "value": "2"})
        between = await ask_where(page, lambda m: m["seq"] is None)
        assert between["pacing"]["state"] == "next" and between["pacing"]["done"] == 1
        t0 = time.monotonic()
        a = await ask_where(page, lambda m: m["seq"] == 1)  # started by the pacer, after iti_ms
        assert time.monotonic() - t0 >= 0.25
        assert a["pacing"]["state"] == "trial"

        await page.send({"type": "answer", "seq": 1, "question": "which", "value": "1"})
        brk = await ask_where(page, lambda m: (m["pacing"] or {}).get("state") == "break")
        assert brk["pacing"]["done"] == 2 and brk["seq"] is None
        await asyncio.sleep(0.6)  # the break holds: nothing starts
        assert (await asyncio.to_thread(statuses, api, sid))[2] == "pending"
        shown = await asyncio.to_thread(api.ok, "GET", f"/api/sessions/{sid}")
        assert shown["pacing"]["state"] == "break" and shown["pacing"]["total"] == 4

        # REST pause during the break: the participant's continue does not start it
        status, _ = await asyncio.to_thread(api.call, "POST", f"/api/sessions/{sid}/pacing/pause", None, "wrong")
        assert status == 403
        await asyncio.to_thread(api.ok, "POST", f"/api/sessions/{sid}/pacing/pause")
        await ask_where(page, lambda m: (m["pacing"] or {}).get("state") == "paused")
        await page.send({"type": "answer", "seq": 0, "question": "pacing:continue", "value": 1})
        assert (await next_error(page))["code"] == "conflict"  # no break is held while paused
        await asyncio.sleep(0.6)
        assert (await asyncio.to_thread(statuses, api, sid))[2] == "pending"
        await asyncio.to_thread(api.ok, "POST", f"/api/sessions/{sid}/pacing/resume")
        a = await ask_where(page, lambda m: m["seq"] == 2)
        assert a["pacing"]["done"] == 2

        await page.send({"type": "answer", "seq": 2, "question": "which", "value": "1"})
        a = await ask_where(page, lambda m: m["seq"] == 3)
        await page.send({"type": "answer", "seq": 3, "question": "which", "value": "2"})
        # the task's end: its questionnaire waits for the experimenter
        end = await ask_where(page, lambda m: m["seq"] is None and m["pacing"] is None)
        assert end["task"] == "pick"
        await page.close()

    asyncio.run(go())
    shown = api.ok("GET", f"/api/sessions/{sid}")
    assert [t["status"] for t in shown["trials"]] == ["answered"] * 4 + ["pending"]
    assert [t["responses"] for t in shown["trials"][:4]] == [{"which": v} for v in ("2", "1", "1", "2")]
    assert shown["running"] is None and shown["pacing"] is None


def test_a_break_ends_with_the_participants_continue(server):
    api = server
    session = api.ok("POST", "/api/sessions", {"study": "paced-live", "participant": "P02", "experimenter": "alice"})
    api.token, sid = session["token"], session["id"]
    mine = participant_token(api.base, sid)

    # the console sees the paced task before anything ran: the experimenter starts it
    wait = time.monotonic() + 5
    while (shown := api.ok("GET", f"/api/sessions/{sid}"))["pacing"] is None and time.monotonic() < wait:
        time.sleep(0.1)
    assert shown["pacing"] == {"state": "experimenter", "done": 0, "total": 4, "feedback": None, "note": ""}

    async def go():
        page = await Client.connect(api.ws, token=mine)
        await page.send({"type": "answer", "seq": 0, "question": "pacing:continue", "value": 1})
        assert (await next_error(page))["code"] == "conflict"  # no break held
        await asyncio.to_thread(api.ok, "POST", f"/api/sessions/{sid}/trials/0/start")
        for seq in (0, 1):
            await ask_where(page, lambda m, seq=seq: m["seq"] == seq)
            await page.send({"type": "answer", "seq": seq, "question": "which", "value": "1"})
        await ask_where(page, lambda m: (m["pacing"] or {}).get("state") == "break")
        await page.send({"type": "answer", "seq": 0, "question": "pacing:continue", "value": 1})
        a = await ask_where(page, lambda m: m["seq"] == 2)
        assert a["pacing"] == {"state": "trial", "done": 2, "total": 4, "feedback": None}
        await page.close()

    asyncio.run(go())
