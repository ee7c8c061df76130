"""A 2IFC staircase session on the real server, driven over REST with the participant's answers;
`kill -9` of the server mid-trial; a restart on the same data directory resumes at the same
procedure state: the next trial's level is the one computed from the recorded answers alone, and
no answer is lost."""

from __future__ import annotations

import os
import signal
import sqlite3
import json
from pathlib import Path

import pytest

from server.experiment.psychophysics_task import Seeds, track
from server.experiment.study import load_study
from tests.integration.test_experiment_live import Api
from tests.live_server import start_server, stop_server

REPO = Path(__file__).resolve().parents[2]
STUDY = "vt-2ifc-staircase"
def answer(psy: dict, threshold: float = 15.0) -> str:
    """A deterministic participant: the right interval above the threshold, the other below."""
    right = str(psy["target"])
    return right if psy["level"] >= threshold else ("1" if right == "2" else "2")


def step(api: Api, sid: str, seq: int, *, finish: bool = True) -> dict:
    started = api.ok("POST", f"/api/sessions/{sid}/trials/{seq}/start")
    api.ok("PUT", f"/api/sessions/{sid}/trials/{seq}/responses/response", {"value": answer(started["psy"])})
    if finish:
        api.ok("POST", f"/api/sessions/{sid}/trials/{seq}/finish")
    return started


def recorded(db_path: Path, sid: str) -> list[tuple[int, dict, str]]:
    """(seq, metrics.psy, stored answer) of every answered main trial, read from the database alone."""
    db = sqlite3.connect(db_path)
    rows = db.execute("SELECT t.seq, t.metrics_json, r.value_json FROM trials t JOIN responses r ON r.trial_id = t.id "
                      "WHERE t.session_id = ? AND t.kind = 'main' AND t.status = 'answered' AND r.question = 'response' "
                      "ORDER BY t.seq", (sid,)).fetchall()
    db.close()
    return [(seq, json.loads(metrics)["psy"], json.loads(value)) for seq, metrics, value in rows]


def test_kill_9_mid_session_resumes_the_staircase_at_the_same_level_with_no_answer_lost(tmp_path):
    data, studies = tmp_path / "data", tmp_path / "studies"
    studies.mkdir()
    # the example file, experimenter-paced (this test drives every trial over REST)
    text = (REPO / "studies" / f"{STUDY}.toml").read_text(encoding="utf-8").split("\n[tasks.pacing]")[0]
    (studies / f"{STUDY}.toml").write_text(text, encoding="utf-8")
    study = load_study(studies / f"{STUDY}.toml")
    assert not study.task("detect").pacing.paced
    psy = study.task("detect").psychophysics
    server_args = ["--data-dir", str(data), "--studies", str(studies)]
    proc, base = start_server("contact-angle", extra=server_args)
    api = Api(base)
    try:
        session = api.ok("POST", "/api/sessions", {"study": STUDY, "participant": "P01", "experimenter": "alice"})
        sid, api.token = session["id"], session["token"]
        before = [step(api, sid, seq) for seq in range(12)]  # 2 practice trials, 10 main
        seq = 12
        interrupted = step(api, sid, seq, finish=False)  # answered, not finished: then the crash
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
    finally:
        stop_server(proc)

    rows = recorded(data / "viestac.sqlite", sid)
    assert [r[0] for r in rows] == list(range(2, 12)), "every finished main trial is on disk"
    assert all(c3["answer"] == stored for _, c3, stored in rows), "its answer with it"
    assert [r[1]["level"] for r in rows] == [t["psy"]["level"] for t in before[2:]]
    seeds = Seeds(study.seed, session["participant_index"], "detect")
    expected = track(psy, seeds, [c3 for _, c3, _ in rows]).level  # from the recorded answers alone

    proc, base = start_server("contact-angle", extra=server_args)
    api = Api(base)
    try:
        view = api.ok("GET", f"/api/sessions/{sid}")
        assert view["next"] == seq and view["trials"][seq]["reason"] == "interrupted"
        assert [t["responses"]["response"] for t in view["trials"][:seq]] == [answer(t["psy"]) for t in before]
        api.token = api.ok("POST", f"/api/sessions/{sid}/control", {"experimenter": "alice"})["token"]
        resumed = step(api, sid, seq)
        assert resumed["psy"]["level"] == pytest.approx(expected)
        assert resumed["psy"] == interrupted["psy"] and resumed["params"] == interrupted["params"]
        assert resumed["attempt"] == 2
        while (nxt := api.ok("GET", f"/api/sessions/{sid}")["next"]) is not None:
            step(api, sid, nxt)
        view = api.ok("GET", f"/api/sessions/{sid}")
        main = [t for t in view["trials"] if t["kind"] == "main"]
        answered = [t for t in main if t["status"] == "answered"]
        assert all(t["status"] == "excluded" and t["reason"] == "procedure finished"
                   for t in main if t["status"] != "answered")
        assert view["status"] == "completed"
        tracks = api.ok("GET", f"/api/sessions/{sid}/tracks")
        (task,) = tracks["tasks"]
        assert tracks["session"] == sid and task["finished"] is True and task["procedure"] == "up-down"
        (condition,) = task["conditions"]
        assert condition["name"] == "main" and condition["finished"] is True
        assert [r["seq"] for r in condition["trials"]] == [t["seq"] for t in answered]
        assert [r["answer"] for r in condition["trials"]] == [t["responses"]["response"] for t in answered]
        assert condition["estimate"] == pytest.approx(answered[-1]["metrics"]["psy"]["estimate"])
    finally:
        stop_server(proc)
