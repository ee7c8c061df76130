"""A participant answers its own study question over /ws (protocol v1.5 `ask`, `answer`) on the
real server: the join link's token is told what the running trial asks, its Likert answer is
recorded as the console's PUT would record it (the REST session shows it, entered by the
participant, with an audit row), and refusals get one clear error each."""

from __future__ import annotations

import asyncio

import pytest

from tests.live_server import get_json, start_server, stop_server
from tests.integration.test_experiment_live import Api
from tests.integration.test_server_ws import Client

STUDY = """
id = "xr-answers"
title = "Participant answers"
seed = 3
participants = 2

[audio]
speech = true

[[tasks]]
id = "angles"
scenario = "contact-angle"
conditions = [{ angle_deg = 10 }]
order = "fixed"
instructions = "Touch the dome, then rate it."

[tasks.audio]
contact_sounds = true

[[tasks.questions]]
id = "sharpness"
kind = "likert"
text = "How sharp was the edge?"
labels = { 1 = "blunt", 7 = "sharp" }
answered_by = "participant"

[[tasks.questions]]
id = "note"
kind = "text"
text = "Anything seen"
required = false
"""


@pytest.fixture
def server(tmp_path):
    studies = tmp_path / "studies"
    studies.mkdir()
    (studies / "xr-answers.toml").write_text(STUDY, encoding="utf-8")
    proc, base = start_server("contact-angle", extra=["--data-dir", str(tmp_path / "data"), "--studies", str(studies),
                                                      "--force"])
    yield Api(base)
    stop_server(proc)


def participant_token(base: str, session_id: str) -> str:
    link = get_json(base + "/api/join-links", "POST", body={"session_id": session_id})
    joined = get_json(base + "/api/auth/join", "POST", body={"code": link["url"].split("#join=", 1)[1]}, token=None)
    assert joined["identity"]["session"] == session_id
    return joined["token"]


async def next_ask(client: Client, seq=..., timeout: float = 5.0) -> dict:
    """The next `ask` (with `seq` when given), skipping state frames and the rest."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout
    while True:
        m = await client.recv_type("ask", timeout=max(0.1, deadline - loop.time()))
        if seq is ... or m["seq"] == seq:
            return m


async def next_error(client: Client) -> dict:
    return await client.recv_type("error", timeout=5.0)


def test_a_participant_answers_a_likert_question_and_the_session_shows_it(server):
    api = server
    session = api.ok("POST", "/api/sessions", {"study": "xr-answers", "participant": "P07", "experimenter": "alice"})
    api.token = session["token"]
    sid = session["id"]
    mine = participant_token(api.base, sid)
    other = api.ok("POST", "/api/sessions", {"study": "xr-answers", "participant": "P08", "experimenter": "alice"})
    stranger = participant_token(api.base, other["id"])  # a participant of another session (opened last)

    async def go():
        page = await Client.connect(api.ws, token=mine)
        first = await next_ask(page)  # after the welcome: nothing runs yet, the next task's audio is on
        assert (first["session"], first["seq"], first["task"], first["questions"]) == (sid, None, "angles", [])
        assert first["audio"] == {"speech": True, "contact_sounds": True}
        assert first["instructions"] == "Touch the dome, then rate it."

        await asyncio.to_thread(api.ok, "POST", f"/api/sessions/{sid}/trials/0/start")
        asked = await next_ask(page, seq=0)
        (q,) = asked["questions"]  # the text question is the experimenter's: not shown
        assert (q["id"], q["kind"], q["low"], q["high"], q["answer"]) == ("sharpness", "likert", 1, 7, None)
        assert q["labels"] == {"1": "blunt", "7": "sharp"}

        await page.send({"type": "answer", "seq": 0, "question": "sharpness", "value": 9})
        assert (await next_error(page))["code"] == "bad_message"          # off the scale: the engine's check
        await page.send({"type": "answer", "seq": 0, "question": "note", "value": "x"})
        assert (await next_error(page))["code"] == "forbidden"            # the experimenter's question
        await page.send({"type": "answer", "seq": 1, "question": "sharpness", "value": 3})
        assert (await next_error(page))["code"] == "conflict"             # not the running trial

        spy = await Client.connect(api.ws, token=stranger)  # its token names the other session
        await spy.send({"type": "answer", "seq": 0, "question": "sharpness", "value": 1})
        assert (await next_error(spy))["code"] == "conflict"  # its own session runs nothing: never reaches P07's
        watcher = await Client.connect(api.ws, role="observer")
        await watcher.send({"type": "answer", "seq": 0, "question": "sharpness", "value": 1})
        assert (await next_error(watcher))["code"] == "forbidden"

        await page.send({"type": "answer", "seq": 0, "question": "sharpness", "value": 6})
        recorded = await next_ask(page, seq=0)
        assert recorded["questions"][0]["answer"] == 6
        for c in (page, spy, watcher):
            await c.close()

    asyncio.run(go())
    shown = api.ok("GET", f"/api/sessions/{sid}")
    assert shown["trials"][0]["responses"] == {"sharpness": 6}  # the console's view of the session
    assert api.ok("GET", f"/api/sessions/{other['id']}")["trials"][0]["responses"] == {}
    api.ok("POST", f"/api/sessions/{sid}/trials/0/finish")  # every required answer is in
    audit = get_json(api.base + "/api/audit")
    rows = [r for r in audit if r["action"] == "ws:answer"]
    assert sorted(r["result"] for r in rows if r["session_id"] == sid) == \
        ["ok", "refused bad_message", "refused conflict", "refused forbidden"]
    assert [r["target"] for r in rows if r["session_id"] == sid and r["result"] == "ok"] == \
        [f"/api/sessions/{sid}/trials/0/responses/sharpness"]  # the console's route for the same answer
    assert [r["result"] for r in rows if r["session_id"] == other["id"]] == ["refused conflict"]
