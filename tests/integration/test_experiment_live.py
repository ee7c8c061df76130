"""The experiment engine on the real server: a scripted experimenter (REST) runs the shipped
thesis study with a scripted participant (WebSocket); bad input and racing consoles get clear
errors; a `kill -9` mid-trial loses only that trial and the session resumes at it."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import sqlite3
import time
import urllib.error
import urllib.request

import pytest

from tests.live_server import auth_headers, start_server, stop_server
from tests.integration.test_server_ws import Client

STUDY = "thesis-2021"


class Api:
    def __init__(self, base: str):
        self.base = base
        self.ws = base.replace("http://", "ws://") + "/ws"
        self.token: str | None = None

    def call(self, method: str, path: str, body: dict | None = None, token: str | None = None):
        """(status, json) of a request; errors are answers too."""
        data = json.dumps(body).encode() if body is not None else None
        headers = {"Content-Type": "application/json", **auth_headers(self.base)}
        if token or self.token:
            headers["X-Control-Token"] = token or self.token
        request = urllib.request.Request(self.base + path, data=data, method=method, headers=headers)
        try:
            with urllib.request.urlopen(request, timeout=10) as response:
                return response.status, json.loads(response.read())
        except urllib.error.HTTPError as exc:
            return exc.code, json.loads(exc.read())

    def ok(self, method: str, path: str, body: dict | None = None) -> dict:
        status, answer = self.call(method, path, body)
        assert status in (200, 201), (status, answer)
        return answer


def new_session(api: Api, participant: str) -> dict:
    session = api.ok("POST", "/api/sessions", {"study": STUDY, "participant": participant, "experimenter": "alice",
                                               "device": "ferrovibe"})
    api.token = session["token"]
    return session


def run_trial(api: Api, sid: str, seq: int, answers: dict | None = None) -> dict:
    api.ok("POST", f"/api/sessions/{sid}/trials/{seq}/start")
    for question, value in (answers or {}).items():
        api.ok("PUT", f"/api/sessions/{sid}/trials/{seq}/responses/{question}", {"value": value})
    return api.ok("POST", f"/api/sessions/{sid}/trials/{seq}/finish")


def answers_for(trial: dict) -> dict:
    return {q: 10.0 for q in trial["questions"]}  # the contact-angle task asks the angle in degrees


async def touch(url: str, seconds: float) -> None:
    """A participant's tracker: press into the dome of the contact-angle scene for a while."""
    client = await Client.connect(url)
    await client.recv_type("scene")
    t0, seq = time.monotonic(), 0
    while time.monotonic() - t0 < seconds:
        await client.send({"type": "tracker", "seq": seq, "t": time.time() * 1e3, "pos": [0.0, 0.3, 0.45]})
        seq += 1
        await asyncio.sleep(0.01)
    await client.close()


@pytest.fixture
def server(tmp_path):
    proc, base = start_server("contact-angle", extra=["--data-dir", str(tmp_path / "data"), "--record-every", "5"])
    yield Api(base), proc, tmp_path / "data" / "viestac.sqlite"
    stop_server(proc)


def test_a_session_runs_with_answers_recordings_and_clear_errors(server):
    api, _, db_path = server
    assert any(s.get("id") == STUDY for s in api.ok("GET", "/api/studies"))
    session = new_session(api, "P01")
    sid, trials = session["id"], session["trials"]
    assert [t["kind"] for t in trials[:5]] == ["training", "trial", "trial", "trial", "main"]
    assert all(t["status"] == "pending" for t in trials) and session["next"] == 0

    # bad input: nothing recorded wrongly
    assert api.call("POST", "/api/sessions", {"study": STUDY, "participant": "P01", "experimenter": "bob"})[0] == 422
    assert api.call("POST", "/api/sessions", {"study": "nope", "participant": "P02", "experimenter": "bob"})[0] == 404
    status, err = api.call("POST", "/api/sessions", {"study": STUDY, "participant": "Jane Doe", "experimenter": "b"})
    assert status == 422 and "pseudonymous" in err["detail"]
    assert api.call("POST", f"/api/sessions/{sid}/trials/2/start")[0] == 409, "not the next trial"
    assert api.call("POST", f"/api/sessions/{sid}/trials/0/start", token="forged")[0] == 403

    run_trial(api, sid, 0)  # training: free exploration, no questions
    api.ok("POST", f"/api/sessions/{sid}/trials/1/start")
    asyncio.run(touch(api.ws, 0.6))
    time.sleep(0.5)  # the participant's tracker stays silent: a tracker loss
    status, err = api.call("POST", f"/api/sessions/{sid}/trials/1/finish")
    assert status == 409 and "needs an answer to answer_deg" in err["detail"]
    status, err = api.call("PUT", f"/api/sessions/{sid}/trials/1/responses/answer_deg", {"value": 200})
    assert status == 422 and "answer_deg" in err["detail"], err
    api.ok("PUT", f"/api/sessions/{sid}/trials/1/responses/answer_deg", {"value": -30})

    # a second console takes control: the first one's token stops working, and the racing start of
    # the same trial by both can only succeed once
    first = api.token
    second = api.ok("POST", f"/api/sessions/{sid}/control", {"experimenter": "bob"})["token"]
    assert api.call("POST", f"/api/sessions/{sid}/trials/1/finish", token=first)[0] == 403
    status, held = api.call("GET", f"/api/sessions/{sid}/control", token=first)
    assert status == 200 and held["yours"] is False and held["experimenter"] == "bob", held
    assert api.call("GET", f"/api/sessions/{sid}/control", token=second)[1]["yours"] is True
    api.token = second
    finished = api.ok("POST", f"/api/sessions/{sid}/trials/1/finish")
    assert finished["status"] == "answered" and finished["attempt"] == 1
    assert 0 < finished["started_tick"] < finished["ended_tick"], "the loop's ticks of the trial"
    api.ok("POST", f"/api/sessions/{sid}/trials/2/start")
    assert api.call("POST", f"/api/sessions/{sid}/trials/2/start")[0] == 409, "already running"
    api.ok("POST", f"/api/sessions/{sid}/trials/2/abort", {"reason": "participant sneezed"})
    assert api.call("POST", f"/api/sessions/{sid}/trials/3/exclude", {"reason": "x"})[0] == 409, "pending"
    api.ok("POST", f"/api/sessions/{sid}/trials/2/retry")
    assert api.ok("GET", f"/api/sessions/{sid}")["next"] == 2
    again = run_trial(api, sid, 2, {"answer_deg": 50})
    assert again["attempt"] == 2
    api.ok("POST", f"/api/sessions/{sid}/trials/1/exclude", {"reason": "outlier"})

    view = api.ok("GET", f"/api/sessions/{sid}")
    by_seq = {t["seq"]: t for t in view["trials"]}
    assert by_seq[1]["status"] == "excluded" and by_seq[1]["responses"] == {"answer_deg": -30.0}
    assert by_seq[2]["status"] == "answered" and by_seq[2]["responses"] == {"answer_deg": 50.0}

    db = sqlite3.connect(db_path)
    samples = db.execute("SELECT COUNT(*), MIN(tick % 5), MAX(contact) FROM samples WHERE trial_id = ?",
                         (by_seq[1]["id"],)).fetchone()
    assert samples[0] > 50 and samples[1] == 0 and samples[2] == 1, "the touch is in the trajectory, every 5th tick"
    events = [(k, json.loads(b)) for k, b in db.execute("SELECT kind, body_json FROM events WHERE trial_id = ? "
                                                          "ORDER BY id", (by_seq[1]["id"],))]
    assert [b["to"] for k, b in events if k == "lifecycle"] == ["running", "answered", "excluded"]
    assert ("tracker", "tracker_lost") in [(k, b.get("name")) for k, b in events], "the tracker stopped mid-trial"
    cues = db.execute("SELECT COUNT(*) FROM cues WHERE trial_id = ?", (by_seq[1]["id"],)).fetchone()[0]
    assert cues >= 1, "the tilt cue of the touch was recorded"
    config = json.loads(db.execute("SELECT config_json FROM sessions").fetchone()[0])
    assert config["record_every"] == 5 and db.execute("SELECT software_version FROM sessions").fetchone()[0]
    db.close()


def test_kill_9_mid_trial_loses_only_it_and_the_session_resumes(tmp_path):
    data = tmp_path / "data"
    proc, base = start_server("contact-angle", extra=["--data-dir", str(data)])
    api = Api(base)
    try:
        session = new_session(api, "P07")
        sid, trials = session["id"], session["trials"]
        for t in trials[:3]:
            run_trial(api, sid, t["seq"], answers_for(t))
        api.ok("POST", f"/api/sessions/{sid}/trials/3/start")
        asyncio.run(touch(api.ws, 0.3))
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
    finally:
        stop_server(proc)
    time.sleep(0.5)  # the loop process notices its parent is gone and exits

    db = sqlite3.connect(data / "viestac.sqlite")
    assert db.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    db.close()
    proc, base = start_server("contact-angle", extra=["--data-dir", str(data)])
    api = Api(base)
    try:
        view = api.ok("GET", f"/api/sessions/{sid}")
        statuses = [t["status"] for t in view["trials"][:5]]
        assert statuses == ["answered", "answered", "answered", "pending", "pending"], statuses
        assert view["next"] == 3 and view["running"] is None and view["trials"][3]["reason"] == "interrupted"
        assert [view["trials"][i]["responses"] for i in (1, 2)] == [{"answer_deg": 10.0}] * 2
        # a restarted server has no controlling console: take control, go on at the 4th trial
        assert api.call("POST", f"/api/sessions/{sid}/trials/3/start")[0] == 403
        api.token = api.ok("POST", f"/api/sessions/{sid}/control", {"experimenter": "alice"})["token"]
        resumed = run_trial(api, sid, 3, answers_for(view["trials"][3]))
        assert resumed["status"] == "answered" and resumed["attempt"] == 2
    finally:
        stop_server(proc)
