"""The battery runs from the console as one session (issue 38 point 4): on a real server the study
list the console's picker shows has every device's battery, a session is created from it like any
study, each participant's parts come in the row of the Latin square the plan gives, and the first
part's trials run through REST with the participant's answers recorded."""

from __future__ import annotations

from pathlib import Path

import pytest

from server.battery.study_file import BUILT_IN
from server.experiment.plan import task_order
from server.experiment.study import load_study
from tests.integration.test_experiment_live import Api
from tests.live_server import start_server, stop_server

ROOT = Path(__file__).resolve().parents[2]
STUDY = "battery-ferrovibe"


@pytest.fixture
def api(tmp_path):
    proc, base = start_server("contact-angle", extra=["--data-dir", str(tmp_path / "data")])
    yield Api(base)
    stop_server(proc)


def parts_in_order(trials: list[dict]) -> list[str]:
    order: list[str] = []
    for t in trials:
        if not order or order[-1] != t["task"]:
            order.append(t["task"])
    return order


def test_the_console_lists_creates_and_runs_a_battery_session_in_its_counterbalanced_order(api):
    listed = {s["id"]: s for s in api.ok("GET", "/api/studies")}
    for model in BUILT_IN:
        assert f"battery-{model}" in listed and not listed[f"battery-{model}"].get("error"), listed.get(f"battery-{model}")

    study = load_study(ROOT / "studies" / f"{STUDY}.toml")
    sessions = []
    for index, participant in enumerate(("P01", "P02", "P03")):
        session = api.ok("POST", "/api/sessions", {"study": STUDY, "participant": participant,
                                                   "experimenter": "alice", "device": "ferrovibe"})
        assert parts_in_order(session["trials"]) == [t.id for t in task_order(study, index)]
        sessions.append(session)
    assert len({tuple(parts_in_order(s["trials"])) for s in sessions}) == 3  # three rows, three orders

    # P01's first part runs: practice and main trials, answers from the participant's choices
    session = sessions[0]
    sid, api.token = session["id"], session["token"]
    first = session["trials"][0]["task"]
    for trial in [t for t in session["trials"] if t["task"] == first][:4]:
        started = api.ok("POST", f"/api/sessions/{sid}/trials/{trial['seq']}/start")
        assert started["task"] == first
        for question in started["questions"]:
            psy = started.get("psy") or {}
            value = (psy.get("choices") or ["1"])[0] if question == "response" else 4
            api.ok("PUT", f"/api/sessions/{sid}/trials/{trial['seq']}/responses/{question}", {"value": value})
        ended = api.ok("POST", f"/api/sessions/{sid}/trials/{trial['seq']}/finish")
        assert ended["status"] == "answered"
        if trial["kind"] == "main" and "response" in started["questions"]:
            assert ended["metrics"]["psy"]["design"] in ("2ifc", "identification")
