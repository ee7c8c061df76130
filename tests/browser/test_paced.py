"""A participant-paced task (docs/studies.md "Participant-paced tasks") from the participant's page
alone, in headless Chromium: the console creates the session and starts the task's first trial;
from then on the participant's keys (and a button) answer, each answer finishes its trial and the
next follows after the inter-trial interval, a break waits for the participant's Continue (Space),
the console's Pause holds the next trial and Resume starts it, and the console's session view
shows the pacing state. In the emulated headset (iwer) the answer panel answers by ray and pinch,
and a break's Continue is a panel too.

The study is a fixture (`paced_study`): a file and what the test needs to know of it. The default is
an ordinary scenario with a participant-answered choice question; a psychophysics study (2IFC
staircase on the stimulus scenario, feedback on) drops in by overriding the fixture, and then the
feedback is checked too."""

from __future__ import annotations

import time
from dataclasses import dataclass

import pytest

from tests.browser.conftest import ARTIFACTS
from tests.browser.test_console import CONSOLE_VIEWPORT, Console, wait_status
from tests.browser.test_pages import contexts  # noqa: F401  (the pages' browser-context fixture)
from tests.browser.test_web_client import READY_TIMEOUT_MS, wait_for
from tests.live_server import LiveServer, get_json, start_server, stop_server

pytestmark = pytest.mark.browser

STUDY = """
id = "paced-choice"
title = "A participant-paced choice"
seed = 5
participants = 4

[[tasks]]
id = "pick"
scenario = "contact-angle"
conditions = [{ angle_deg = 10 }, { angle_deg = 20 }, { angle_deg = 30 }, { angle_deg = 40 }, { angle_deg = 50 }]
order = "fixed"
instructions = "Touch the dome, then answer: 1 or 2."

[tasks.pacing]
by = "participant"
iti_ms = 400
feedback = true
feedback_ms = 300
break_every = 2

[[tasks.questions]]
id = "which"
kind = "choice"
text = "Which interval held the stimulus?"
choices = ["1", "2"]
answered_by = "participant"
"""


@dataclass(frozen=True)
class PacedStudy:
    """A study file whose first task is participant-paced with `break_every = 2` and at least 5
    trials, answered by one participant choice question."""
    text: str
    study_id: str
    question: str
    choices: tuple[str, ...]
    scenario: str = "contact-angle"   # what the server starts with
    feedback: bool = False            # its trials carry metrics.psy.correct: feedback must show


@pytest.fixture(scope="module")
def paced_study() -> PacedStudy:
    return PacedStudy(STUDY, "paced-choice", "which", ("1", "2"))


@pytest.fixture(scope="module")
def paced_server(tmp_path_factory, paced_study):
    studies = tmp_path_factory.mktemp("studies")
    (studies / f"{paced_study.study_id}.toml").write_text(paced_study.text, encoding="utf-8")
    proc, base = start_server(paced_study.scenario, extra=["--studies", str(studies), "--force"])
    try:
        yield LiveServer(base, base.replace("http://", "ws://") + "/ws")
    finally:
        stop_server(proc)


def trials(server: LiveServer, sid: str) -> list[dict]:
    return server.get(f"/api/sessions/{sid}")["trials"]


def console_session(page, server: LiveServer, study: PacedStudy, participant: str) -> tuple[Console, str]:
    """The console creates the session (it holds its control token) and starts its first trial."""
    console = Console(page, server).open()
    page.wait_for_function("(id) => [...document.querySelectorAll('#study option')].some(o => o.value === id)",
                           arg=study.study_id, timeout=READY_TIMEOUT_MS)
    page.select_option("#study", study.study_id)
    page.fill("#experimenter", "alice")
    page.fill("#participant", participant)
    page.click("#create")
    console.wait_state("s.sessionId && s.control === 'yes' && s.next === 0")
    return console, console.state()["sessionId"]


def join(page, server: LiveServer, sid: str, query: str = "") -> None:
    """The participant's page opens the session's join link (its own token: the session's participant)."""
    link = get_json(f"{server.http_url}/api/join-links", "POST", body={"session_id": sid})
    code = link["url"].split("#join=", 1)[1]
    page.goto(f"{server.http_url}/{query}#join={code}")
    page.wait_for_function("window.__viestac && window.__viestac.ready && window.__viestac.identity",
                           timeout=READY_TIMEOUT_MS)


def wait_asked(page, seq: int, timeout_ms: int = 10_000) -> None:
    page.wait_for_function("(seq) => window.__viestac.ask?.seq === seq && window.__viestac.pacing()?.progress",
                           arg=seq, timeout=timeout_ms)


def shot(page, name: str) -> None:
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / f"paced-{name}.png"))


def test_a_paced_task_runs_from_the_participants_keys(contexts, paced_server, paced_study):  # noqa: F811
    server, study = paced_server, paced_study
    console, sid = console_session(contexts(server, viewport=CONSOLE_VIEWPORT), server, study, "P11")
    participant = contexts(server, token=None)
    errors: list[str] = []
    participant.on("pageerror", lambda e: errors.append(str(e)))
    join(participant, server, sid)
    first, second = study.choices[0], study.choices[1]

    console.click("#start")  # the experimenter starts the task; the participant's answers do the rest
    wait_asked(participant, 0)
    assert participant.inner_text("#pacing .progress") == "Trial 1 of 5"
    assert participant.get_attribute(f'#answer button[data-value="{first}"]', "aria-keyshortcuts").startswith("1")
    console.wait_text("#pacing-state", "the participant answers")
    shot(participant, "trial")

    participant.keyboard.press("2")  # the second choice
    wait_status(server, sid, 0, "answered")
    wait_asked(participant, 1)  # started by the pacer, without the console
    assert participant.inner_text("#pacing .progress") == "Trial 2 of 5"

    participant.keyboard.press("1")
    wait_status(server, sid, 1, "answered")
    participant.wait_for_selector("#pacing .continue:not([hidden])")  # a break after 2 trials
    assert "Break: 2 of 5 done" in participant.inner_text("#pacing .text")
    console.wait_text("#pacing-state", "break")
    shot(participant, "break")
    shot(console.page, "console-break")
    time.sleep(1.0)
    assert trials(server, sid)[2]["status"] == "pending", "the break holds until the participant continues"

    participant.keyboard.press(" ")  # Continue
    wait_asked(participant, 2)
    assert participant.is_hidden("#pacing .continue")

    # the experimenter pauses while trial 2 runs: its answer still ends it, the next does not start
    console.wait_text("#pacing-state", "the participant answers")
    console.click("#pace-pause")
    console.wait_text("#run-msg", "Paused")
    participant.keyboard.press("1")
    wait_status(server, sid, 2, "answered")
    participant.wait_for_function("window.__viestac.pacing()?.text === 'Paused by the experimenter.'")
    time.sleep(1.0)
    assert trials(server, sid)[3]["status"] == "pending", "paused: nothing starts"
    console.wait_text("#pacing-state", "paused")
    shot(participant, "paused")

    console.click("#pace-resume")
    wait_asked(participant, 3)
    participant.click(f'#answer button[data-value="{second}"]')  # a button answers too
    wait_status(server, sid, 3, "answered")
    participant.wait_for_selector("#pacing .continue:not([hidden])")  # the second break (4 of 5)
    participant.click("#pacing .continue")  # the button continues too
    wait_asked(participant, 4)
    participant.keyboard.press("1")
    wait_status(server, sid, 4, "answered")

    done = trials(server, sid)
    assert [t["responses"][study.question] for t in done[:5]] == [second, first, first, second, first] \
        if study.choices == ("1", "2") else True
    assert all(t["status"] == "answered" for t in done[:5])
    seen = participant.evaluate("window.__viestac.pacingSeen")
    assert "break" in seen and "paused" in seen and "next" in seen, seen
    if study.feedback:  # a psychophysics study: the procedure knows the right answer
        assert any(s.startswith("feedback:") for s in seen), seen
    else:  # no metrics.psy.correct: no feedback, although the file asks for it
        assert not any(s.startswith("feedback") for s in seen), seen
    assert not errors and not console.page_errors


# -- the emulated headset ------------------------------------------------------------------------

# Point the right hand's target ray at a button of the answer panel: the hand stands 0.3 m in
# front of the button and turns to face it (a ray is the hand's −Z); then the hand pinches.
AIM = """([value]) => { const v = window.__viestac; const d = v.xrDevice, panel = v.xr.choice;
    const b = (panel.buttons ?? []).find((x) => String(x.value) === String(value));
    if (!b || !panel.mesh.visible) return false;
    const mesh = panel.mesh; mesh.updateMatrixWorld();
    const V = mesh.position.constructor;
    // a button's centre: its u range across, the lower half of the panel (xr_view.js TextPanel.show)
    const target = mesh.localToWorld(new V(((b.u0 + b.u1) / 2 - 0.5) * panel.widthM, -0.25 * panel.heightM, 0));
    const normal = new V(0, 0, 1).transformDirection(mesh.matrixWorld);
    const from = target.clone().addScaledVector(normal, 0.3);
    d.hands.right.position.set(from.x, from.y, from.z);
    const m = new mesh.matrixWorld.constructor().lookAt(from, target, new V(0, 1, 0));
    const q = new mesh.quaternion.constructor().setFromRotationMatrix(m);
    d.hands.right.quaternion.set(q.x, q.y, q.z, q.w);
    return true; }"""
SELECTED = "window.__viestac.xr.choice.buttons.find((b) => b.selected)?.value"
PINCH = "([value]) => window.__viestac.xrDevice.hands.right.updatePinchValue(value)"


def pinch(page, value) -> None:
    """Aim at the button for `value`, wait until the panel highlights it, then pinch and let go."""
    wait_for(lambda: page.evaluate(AIM, [value]), timeout=10, what=f"the answer panel's button {value}")
    wait_for(lambda: page.evaluate(AIM, [value]) and str(page.evaluate(SELECTED)) == str(value), timeout=10,
             what=f"the ray on the button {value}")
    page.evaluate(PINCH, [1])
    page.wait_for_timeout(300)
    page.evaluate(PINCH, [0])


def test_the_emulated_headset_answers_a_paced_task_by_pinch(contexts, paced_server, paced_study):  # noqa: F811
    server, study = paced_server, paced_study
    console, sid = console_session(contexts(server, viewport=CONSOLE_VIEWPORT), server, study, "P12")
    page = contexts(server, token=None)
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    join(page, server, sid, "?xr_emulator=quest3&xr_ttl=400")
    page.wait_for_function("window.__viestac.xrDevice", timeout=READY_TIMEOUT_MS)
    page.click("#xr button[data-mode=immersive-vr]")
    page.wait_for_function("window.__viestac.xr.active && window.__viestac.xr.stats.frames > 5", timeout=20_000)

    console.click("#start")
    wait_asked(page, 0)
    pinch(page, study.choices[1])
    wait_status(server, sid, 0, "answered")
    wait_asked(page, 1)  # the pacer's next trial
    pinch(page, study.choices[0])
    wait_status(server, sid, 1, "answered")
    page.wait_for_function("window.__viestac.pacing()?.continue === true")  # the break: a Continue panel
    pinch(page, 1)
    wait_asked(page, 2)
    responses = [t["responses"].get(study.question) for t in trials(server, sid)[:2]]
    assert responses == [study.choices[1], study.choices[0]]
    assert not errors and not console.page_errors
