"""The experimenter console (clients/web/console.html) in headless Chromium against a server of its
own: create a session of the shipped thesis study, run its first trials with the buttons and the
answer form, abort and retry one, and check through REST that the session is what the clicks did;
a second console taking control shows up in the first. Screenshots go to
tests/artifacts/browser/console-*.png.

Reuses the browser fixture (tests/browser/conftest.py) and the helpers of test_web_client.py.
"""

from __future__ import annotations

import math
import shutil
import time
import urllib.request
from pathlib import Path

import pytest

from tests.live_server import start_server, stop_server
from tests.browser.conftest import ARTIFACTS, auth_header, new_context, require_web_deps
from tests.browser.test_web_client import READY_TIMEOUT_MS, VIEWPORT, Client, wait_for
from tests.live_server import LiveServer

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parents[2]
STUDY = "thesis-2021"
CONSOLE_VIEWPORT = {"width": 1440, "height": 900}
BROKEN_STUDY = 'id = "broken"\ntitle = "A broken study"\nseed = 1\nparticipants = 2\ncolour = "red"\n'


@pytest.fixture(scope="module")
def console_server(tmp_path_factory):
    """A server with its own database and a studies directory holding the shipped thesis study and
    a broken study file (the console lists it with its error)."""
    studies = tmp_path_factory.mktemp("studies")
    shutil.copy(ROOT / "studies" / f"{STUDY}.toml", studies / f"{STUDY}.toml")
    (studies / "broken.toml").write_text(BROKEN_STUDY)
    proc, base = start_server("contact-angle", extra=["--studies", str(studies)])
    try:
        yield LiveServer(base, base.replace("http://", "ws://") + "/ws")
    finally:
        stop_server(proc)


class Console:
    """One browser page running the console."""

    def __init__(self, page, server: LiveServer):
        self.page = page
        self.server = server
        self.page_errors: list[str] = []
        page.on("pageerror", lambda e: self.page_errors.append(str(e)))

    def open(self, fragment: str = "") -> "Console":
        self.page.goto(f"{self.server.http_url}/console.html{fragment}")
        self.page.wait_for_function("window.__console && window.__console.ready", timeout=READY_TIMEOUT_MS)
        return self

    def state(self) -> dict:
        return self.page.evaluate("window.__console.state()")

    def wait_state(self, js_condition: str, timeout_ms: int = 10_000) -> None:
        self.page.wait_for_function(f"(() => {{ const s = window.__console.state(); return {js_condition}; }})()",
                                    timeout=timeout_ms)

    def click(self, selector: str) -> None:
        self.page.click(selector)

    def text(self, selector: str) -> str:
        return self.page.inner_text(selector)

    def wait_text(self, selector: str, fragment: str, timeout_ms: int = 10_000) -> None:
        self.page.wait_for_function(
            "([sel, frag]) => (document.querySelector(sel)?.innerText ?? '').includes(frag)",
            arg=[selector, fragment], timeout=timeout_ms)


@pytest.fixture
def open_page(browser):
    require_web_deps()  # the participant's view in the console imports three.js
    contexts = []

    def make(viewport=CONSOLE_VIEWPORT, server: LiveServer | None = None, token=True):
        ctx = new_context(browser, server.http_url, token=token, viewport=viewport) if server \
            else browser.new_context(viewport=viewport)
        contexts.append(ctx)
        return ctx.new_page()

    yield make
    for ctx in contexts:
        ctx.close()


def session_view(server: LiveServer, sid: str) -> dict:
    return server.get(f"/api/sessions/{sid}")


def trial(server: LiveServer, sid: str, seq: int) -> dict:
    return next(t for t in session_view(server, sid)["trials"] if t["seq"] == seq)


def wait_status(server: LiveServer, sid: str, seq: int, status: str) -> dict:
    return wait_for(lambda: (t := trial(server, sid, seq))["status"] == status and t, timeout=10,
                    what=f"trial {seq} {status}")


def touch_the_dome(participant: Client, seconds: float) -> None:
    """Move the participant's pointer in and out of the contact-angle dome (radius 0.6) for a while."""
    page = participant.page
    t0 = time.monotonic()
    k = 0
    while time.monotonic() - t0 < seconds:
        a = math.radians(-80 + (k * 9) % 160)  # sweep the arc from left to right
        r = 0.45 if (k // 6) % 2 == 0 else 0.8  # inside the dome, then out of it
        x, y = participant.screen((0.0, r * math.sin(a), r * math.cos(a)))
        page.mouse.move(x, y, steps=3)
        page.wait_for_timeout(40)
        k += 1


def test_console_runs_a_session(open_page, console_server):
    server = console_server
    console = Console(open_page(server=server), server).open()
    page = console.page

    # the studies: the shipped one usable, the broken file listed with its error
    console.wait_text("#study-errors", "broken.toml")
    assert "colour" in console.text("#study-errors"), console.text("#study-errors")
    assert page.input_value("#study") == STUDY
    page.click("#study-tasks summary")
    assert "contact_angle" in console.text("#tasks-table") and "answer_deg" in console.text("#tasks-table")
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / "console-setup.png"), full_page=True)
    page.click("#study-tasks summary")

    # a name is refused before it reaches the server; a code makes the session
    page.fill("#experimenter", "alice")
    page.fill("#participant", "Jane Doe")
    page.click("#create")
    console.wait_text("#create-msg", "must not be a name")
    page.fill("#participant", "P42")
    page.fill("#device", "ferrovibe")
    page.fill("#notes", "console browser test")
    page.click("#create")
    console.wait_state("s.sessionId && s.control === 'yes' && s.next === 0")
    sid = console.state()["sessionId"]
    view = session_view(server, sid)
    assert view["participant"] == "P42" and view["experimenter"] == "alice" and view["device"] == "ferrovibe"
    assert page.locator("#queue tbody tr").count() == len(view["trials"])
    assert page.locator('#queue tr.c-next[data-seq="0"]').count() == 1
    # a second session for the same participant is refused, in plain words, and nothing is lost
    page.click("#setup > summary")
    page.fill("#participant", "P42")
    page.click("#create")
    console.wait_text("#create-msg", "already has a session")
    assert page.input_value("#participant") == "P42"
    page.click("#setup > summary")

    # the participant's page, sending the HIP; it must never ask for sessions, studies or answers
    participant_page = open_page(VIEWPORT, server=server)
    participant_urls: list[str] = []
    participant_page.on("request", lambda r: participant_urls.append(r.url))
    participant = Client(participant_page, server).open()

    # training (free exploration): start it, let the participant touch the dome, watch it live
    page.click("#start")
    wait_status(server, sid, 0, "running")
    page.wait_for_selector('#queue tr.c-running[data-seq="0"]')
    touch_the_dome(participant, 3.0)
    page.wait_for_function("window.__console.lanes().find(l => l.id === 'tilt').runs > 0", timeout=10_000)
    page.wait_for_function("window.__console.lanes().find(l => l.id === 'contact').runs > 0")
    assert page.evaluate("window.__console.trajectory()") > 30
    touch_the_dome(participant, 1.0)
    page.screenshot(path=str(ARTIFACTS / "console-live.png"), full_page=True)
    page.locator(".c-live").screenshot(path=str(ARTIFACTS / "console-live-panels.png"))
    page.click("#finish")
    wait_status(server, sid, 0, "answered")

    # the first practice trial of the contact-angle task: the answer form asks the angle
    page.click("#start")
    first = wait_status(server, sid, 1, "running")
    assert first["kind"] == "trial" and first["task"] == "contact_angle" and first["questions"] == ["answer_deg"]
    angle = page.locator('fieldset[data-question="answer_deg"] input[type="number"]')
    angle.wait_for()
    assert angle.get_attribute("min") == "-90" and angle.get_attribute("max") == "90"
    assert "answer_deg" in console.text("#finish-hint")
    page.click("#finish")  # nothing answered yet: refused by the page, the trial keeps running
    console.wait_text("#run-msg", "answer answer_deg")
    assert trial(server, sid, 1)["status"] == "running"
    angle.fill("200")  # out of the scale: refused next to the field, the typed value stays
    page.click("#save-answers")
    console.wait_text('fieldset[data-question="answer_deg"] .c-field-error', "from -90 to 90")
    assert angle.input_value() == "200" and trial(server, sid, 1)["responses"] == {}
    angle.fill("-10")
    console.wait_text("#finish-hint", "All required answers are in")
    page.screenshot(path=str(ARTIFACTS / "console-queue.png"), full_page=True)
    page.click("#finish")
    wait_status(server, sid, 1, "answered")
    console.wait_text("#run-msg", "finished")

    # the second practice trial: abort it with a reason, then retry it
    page.click("#start")
    wait_status(server, sid, 2, "running")
    page.fill("#abort-reason", "participant sneezed")
    page.click("#abort")
    aborted = wait_status(server, sid, 2, "aborted")
    assert aborted["reason"] == "participant sneezed"
    page.wait_for_selector("#retry-actions:not([hidden])")
    page.click("#retry")
    wait_status(server, sid, 2, "pending")
    console.wait_state("s.next === 2 && s.running === null")

    # a racing change from elsewhere (REST with this console's token) gives a 409 in plain words
    page.evaluate("window.__console.pause(true)")
    token = page.evaluate(f"sessionStorage.getItem('viestac.console.token.{sid}')")
    req = urllib.request.Request(f"{server.http_url}/api/sessions/{sid}/trials/2/start", method="POST",
                                 headers={"X-Control-Token": token, **auth_header(server.http_url)})
    urllib.request.urlopen(req, timeout=5).read()
    page.click("#start")  # the page still thinks trial 2 is next
    console.wait_text("#run-msg", "Not possible now")
    assert "running" in console.text("#run-msg")
    page.evaluate("window.__console.pause(false)")
    console.wait_state("s.running === 2")
    page.fill("#abort-reason", "started twice")
    page.click("#abort")
    wait_status(server, sid, 2, "aborted")

    # exclude the training trial: a reason is required
    page.click('#queue tr[data-seq="0"]')
    page.wait_for_selector("#exclude-actions:not([hidden])")
    page.click("#exclude")
    console.wait_text("#trial-msg", "Give a reason")
    page.fill("#exclude-reason", "training cut short")
    page.click("#exclude")
    wait_status(server, sid, 0, "excluded")

    # the session is what the clicks did
    view = session_view(server, sid)
    by_seq = {t["seq"]: t for t in view["trials"]}
    assert [by_seq[i]["status"] for i in range(4)] == ["excluded", "answered", "aborted", "pending"]
    assert by_seq[0]["reason"] == "training cut short"
    assert by_seq[1]["responses"] == {"answer_deg": -10.0} and by_seq[1]["attempt"] == 1
    assert by_seq[2]["attempt"] == 2 and by_seq[2]["reason"] == "started twice" and by_seq[2]["responses"] == {}
    assert view["running"] is None and view["next"] == 3

    # a second console takes control: the first one shows that it lost it
    other = Console(open_page(server=server), server).open(f"#session={sid}")
    other.wait_state(f"s.sessionId === '{sid}' && s.control === 'none'")
    assert other.page.is_visible("#take-control") and other.page.is_disabled("#start")
    other.page.fill("#experimenter", "bob")
    other.page.click("#take-control")
    other.wait_state("s.control === 'yes'")
    console.wait_state("s.control === 'lost'", timeout_ms=8_000)
    assert page.is_visible("#take-control") and page.is_disabled("#start")
    assert "Session control lost" in console.text("#control")
    page.screenshot(path=str(ARTIFACTS / "console-lost-control.png"), full_page=True)
    # and takes it back
    page.click("#take-control")
    console.wait_state("s.control === 'yes'")
    other.wait_state("s.control === 'lost'", timeout_ms=8_000)

    assert not [u for u in participant_urls if "/api/sessions" in u or "/api/studies" in u], participant_urls
    assert not console.page_errors, console.page_errors
    assert not other.page_errors, other.page_errors
    assert not participant.page_errors, participant.page_errors


def test_finish_checks_the_answers_against_the_session_read_after_saving_them(open_page, console_server):
    """Finish saves the typed answer, reloads the session and checks it is in. A periodic refresh
    that overtakes that reload must not leave the check looking at the session from before the
    save (which has no answer, while the typed draft is gone once saved): every session read is
    made slower than the 2 s refresh period here, so one always overtakes it."""
    server = console_server
    console = Console(open_page(server=server), server).open()
    page = console.page
    page.fill("#experimenter", "alice")
    page.fill("#participant", "P43")
    page.fill("#device", "ferrovibe")
    page.click("#create")
    console.wait_state("s.sessionId && s.control === 'yes' && s.next === 0")
    sid = console.state()["sessionId"]
    page.click("#start")
    wait_status(server, sid, 0, "running")
    page.click("#finish")  # the training asks nothing
    wait_status(server, sid, 0, "answered")
    console.wait_state("s.next === 1 && s.running === null")
    page.click("#start")
    wait_status(server, sid, 1, "running")
    angle = page.locator('fieldset[data-question="answer_deg"] input[type="number"]')
    angle.wait_for()
    angle.fill("30")
    console.wait_text("#finish-hint", "All required answers are in")

    def slow_session_read(route):
        time.sleep(2.5)  # longer than the console's refresh period (REFRESH_MS, 2 s)
        route.continue_()

    from playwright.sync_api import TimeoutError as PlaywrightTimeout  # (the browser tests skip without it)

    page.route(f"**/api/sessions/{sid}", slow_session_read)  # handled while Playwright waits below
    page.click("#finish")
    try:
        console.wait_text("#run-msg", "finished (answered)", timeout_ms=30_000)
    except PlaywrightTimeout:
        pytest.fail(f"Finish did not finish; the page says: {console.text('#run-msg')!r}")
    page.unroute(f"**/api/sessions/{sid}")
    answered = trial(server, sid, 1)
    assert answered["status"] == "answered" and answered["responses"] == {"answer_deg": 30.0}
    assert not console.page_errors, console.page_errors
