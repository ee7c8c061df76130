"""The battery runs from the console as one session (issue 38 point 4): on a real server the study
list the console's picker shows has every device's battery, a session is created from it like any
study, and each participant's parts come in the row of the Latin square the plan gives. Then a lab's
run of a (small) battery: the experimenter starts a part over REST with the control token, the
participant's answers over /ws move its trials on by themselves (participant-paced), a break holds
until the participant continues, and at the part's end the session waits for the experimenter, who
starts the next part of the participant's row."""

from __future__ import annotations

import asyncio
import re
import time
from pathlib import Path

import pytest

from server.battery.parts import PACING
from server.battery.study_file import BUILT_IN, battery_study
from server.experiment.pacing import CONTINUE_QUESTION
from server.experiment.plan import task_order
from server.experiment.study import load_study, parse_study
from tests.integration.test_experiment_live import Api
from tests.integration.test_paced_live import ask_where
from tests.integration.test_participant_answers_live import participant_token
from tests.integration.test_server_ws import Client
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


def console_pacing(api: Api, sid: str) -> dict | None:
    """The console's view of the session's pacing (a session the pacer has not seen yet is looked at
    on this read: the next ones show it)."""
    wait = time.monotonic() + 5
    while (shown := api.ok("GET", f"/api/sessions/{sid}"))["pacing"] is None and time.monotonic() < wait:
        time.sleep(0.1)
    return shown["pacing"]


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

    # every psychophysics part is participant-paced; the session waits for the experimenter to start it
    paced = {t.id for t in study.tasks if t.pacing.paced}
    assert paced == {t.id for t in study.tasks if t.psychophysics is not None}
    first = sessions[0]["trials"][0]["task"]
    assert first in paced and console_pacing(api, sessions[0]["id"])["state"] == "experimenter"


# -- a lab's run of a small battery ------------------------------------------------------------
BREAK_EVERY = 2


def small_battery(model: str) -> str:
    """The device's battery as generated now, made small: 3 main trials a staircase part (2 practice
    first), one repeat of each angle, a break every BREAK_EVERY trials, no positioning part (it is
    experimenter-paced, and its tracking is tested elsewhere)."""
    body, blocks = battery_study(model).split("\n[[blocks]]\n")
    head, *tasks = body.split("\n[[tasks]]\n")
    kept = []
    for task in tasks:
        if task.startswith('id = "positioning"'):
            continue
        levels = re.search(r"^levels = \[(.*)\]$", task, flags=re.M)
        trials = len(levels[1].split(",")) if levels else 3
        task = re.sub(r"^max_trials = \d+$", f"max_trials = {trials}", task, flags=re.M)
        task = re.sub(r"^repeats = \d+$", "repeats = 1", task, flags=re.M)
        task = re.sub(r"^break_every = \d+$", f"break_every = {BREAK_EVERY}", task, flags=re.M)
        kept.append(task)
    return "\n[[tasks]]\n".join([head, *kept]) + "\n[[blocks]]\n" + blocks.replace(', "positioning"]', "]")


@pytest.fixture
def small(tmp_path):
    studies = tmp_path / "studies"
    studies.mkdir()
    text = small_battery("ferrovibe")
    (studies / f"{STUDY}.toml").write_text(text, encoding="utf-8")
    proc, base = start_server("contact-angle", extra=["--data-dir", str(tmp_path / "data"), "--studies", str(studies),
                                                      "--force"])
    yield Api(base), parse_study(text, f"{STUDY}.toml")
    stop_server(proc)


def stimulus_s(task) -> float:
    """A trial's stimulus (Contract C1): lead, the intervals and the gaps between them."""
    p, n = task.params, task.psychophysics.design.intervals
    return (p["lead_ms"] + n * p["duration_ms"] + (n - 1) * p["isi_ms"]) / 1000


def trials_of(api: Api, sid: str) -> list[dict]:
    return api.ok("GET", f"/api/sessions/{sid}")["trials"]


def test_a_battery_runs_as_one_participant_paced_session_part_after_part(small):
    api, study = small
    api.ok("POST", "/api/sessions", {"study": STUDY, "participant": "P01", "experimenter": "alice", "device": "ferrovibe"})
    session = api.ok("POST", "/api/sessions", {"study": STUDY, "participant": "P02", "experimenter": "alice",
                                               "device": "ferrovibe"})  # the second row of the square
    sid, api.token = session["id"], session["token"]
    row = [t.id for t in task_order(study, 1)]
    assert parts_in_order(session["trials"]) == row and row[:2] != [t.id for t in study.tasks][:2]
    first, second = row[0], row[1]
    part_one = [t for t in session["trials"] if t["task"] == first]
    part_two = [t for t in session["trials"] if t["task"] == second]
    assert len(part_one) == 5 and part_two[0]["seq"] == part_one[-1]["seq"] + 1  # 2 practice and 3 main trials
    assert console_pacing(api, sid) == {"state": "experimenter", "done": 0, "total": 5, "feedback": None, "note": ""}
    mine = participant_token(api.base, sid)
    iti_s = PACING["iti_ms"] / 1000

    async def answer(page: Client, seq: int) -> dict:
        """The participant answers trial `seq` (its first choice) once its stimulus has played."""
        asked = await ask_where(page, lambda m: m["seq"] == seq and (m["pacing"] or {}).get("state") == "trial")
        await asyncio.sleep(stimulus_s(study.task(asked["task"])))
        question = asked["questions"][0]
        await page.send({"type": "answer", "seq": seq, "question": question["id"], "value": question["choices"][0]})
        return asked

    async def go():
        page = await Client.connect(api.ws, token=mine)
        ready = await ask_where(page, lambda m: (m["pacing"] or {}).get("state") == "experimenter")
        assert ready["task"] == first and ready["seq"] is None

        # the experimenter starts the part; from then on the participant's answers move it on
        started = await asyncio.to_thread(api.ok, "POST", f"/api/sessions/{sid}/trials/{part_one[0]['seq']}/start")
        assert started["task"] == first
        answered = 0.0
        for k, trial in enumerate(part_one):
            asked = await answer(page, trial["seq"])
            assert asked["task"] == first and asked["pacing"]["done"] == k and asked["pacing"]["total"] == 5
            if k and k % BREAK_EVERY:  # started by the pacer an inter-trial interval after the answer
                assert time.monotonic() - answered >= iti_s - 0.1
            answered = time.monotonic()
            if (k + 1) % BREAK_EVERY == 0 and k + 1 < len(part_one):  # a break every BREAK_EVERY trials
                brk = await ask_where(page, lambda m: (m["pacing"] or {}).get("state") == "break")
                assert brk["seq"] is None and brk["pacing"]["done"] == k + 1
                await asyncio.sleep(iti_s + 0.5)  # the break holds: nothing starts
                assert (await asyncio.to_thread(trials_of, api, sid))[part_one[k + 1]["seq"]]["status"] == "pending"
                await page.send({"type": "answer", "seq": 0, "question": CONTINUE_QUESTION, "value": 1})
        # the part's end: the pacer stops, the session waits for the experimenter at the row's next part
        end = await ask_where(page, lambda m: m["seq"] is None and (m["pacing"] or {}).get("state") == "experimenter")
        assert end["task"] == second and end["pacing"]["done"] == 0
        await asyncio.sleep(iti_s + 0.5)
        assert (await asyncio.to_thread(trials_of, api, sid))[part_two[0]["seq"]]["status"] == "pending"

        started = await asyncio.to_thread(api.ok, "POST", f"/api/sessions/{sid}/trials/{part_two[0]['seq']}/start")
        assert started["task"] == second
        await answer(page, part_two[0]["seq"])
        await answer(page, part_two[1]["seq"])  # started by the pacer: the next part is paced too
        await page.close()

    asyncio.run(go())
    shown = trials_of(api, sid)
    ended = [shown[t["seq"]] for t in part_one]
    assert [t["status"] for t in ended] == ["answered"] * 5
    for trial in ended:
        assert trial["task"] == first
        if trial["kind"] == "main":
            assert trial["metrics"]["psy"]["design"] in ("2ifc", "identification")
