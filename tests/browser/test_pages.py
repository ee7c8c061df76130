"""The participant page and the console's live pieces on a busy machine (issue 34 points 1, 2, 3,
8 and the page items of 9), against a server of its own with two small studies:

- a page whose hello is slow is admitted (the server's grace period), and one whose first hello
  never comes is refused and connects again by itself with its stored token;
- a participant whose session is closed mid-trial sees one state ("waiting…", no question beside
  it), and the stale `forbidden` goes once the session is open again;
- a tab whose session another tab took says so and only watches;
- the lease card is not rebuilt under the pointer, warns before a Release closes a participant
  session mid-trial and says so when it happened;
- the console's messages and buttons follow the server's state; the participant code rule; the
  hidden answer row really hidden; the live view's layout at 1400 px.

Screenshots: tests/artifacts/browser/pages-*.png.
"""

from __future__ import annotations

import pytest

from tests.browser.conftest import ARTIFACTS, new_context, require_web_deps
from tests.browser.test_console import Console, session_view, wait_status
from tests.browser.test_web_client import READY_TIMEOUT_MS, VIEWPORT, Client, wait_for
from tests.integration.test_participant_answers_live import STUDY as ANSWERS_STUDY
from tests.live_server import LiveServer, get_json, start_server, stop_server

pytestmark = pytest.mark.browser

TWO_TRIALS = """
id = "two-trials"
title = "Two trials and a note"
seed = 1
participants = 4

[[tasks]]
id = "angles"
scenario = "contact-angle"
conditions = [{ angle_deg = 10 }]
repetitions = 2
order = "fixed"

[[tasks.questions]]
id = "note"
kind = "text"
text = "Anything seen"
required = false
"""

# Every WebSocket of the page sends its first frame (the hello) this late: slower than the old 1 s
# grace period, well within the new one.
SLOW_HELLO_MS = 2500
SLOW_HELLO = """(() => {
  const send = WebSocket.prototype.send;
  WebSocket.prototype.send = function (data) {
    if (this.__helloSent) return send.call(this, data);
    this.__helloSent = true;
    const ws = this;
    setTimeout(() => { if (ws.readyState === 1) send.call(ws, data); }, %d);
  };
})();""" % SLOW_HELLO_MS

# The page's first WebSocket never says hello (a page frozen right after connecting); later ones do.
LOST_FIRST_HELLO = """(() => {
  const send = WebSocket.prototype.send;
  let sockets = 0;
  const Native = WebSocket;
  window.WebSocket = class extends Native {
    constructor(...a) { super(...a); this.__n = ++sockets; }
  };
  WebSocket.prototype.send = function (data) {
    if (this.__n === 1) return undefined;
    return send.call(this, data);
  };
  Object.assign(window.WebSocket, { CONNECTING: 0, OPEN: 1, CLOSING: 2, CLOSED: 3 });
})();"""

# Session GETs of the console answer late while window.__slowSessionMs is set (a loaded server).
SLOW_SESSION_GET = """(() => {
  const f = window.fetch.bind(window);
  window.fetch = async (url, init) => {
    const ms = window.__slowSessionMs;
    if (ms && (!init || !init.method || init.method === 'GET') && /\\/api\\/sessions\\/[^/?]+$/.test(String(url))) {
      await new Promise((r) => setTimeout(r, ms));
    }
    return f(url, init);
  };
})();"""


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    """A server whose harness admin holds the lease; studies: xr-answers (a participant question)
    and two-trials (two trials with an optional experimenter note)."""
    studies = tmp_path_factory.mktemp("studies")
    (studies / "xr-answers.toml").write_text(ANSWERS_STUDY, encoding="utf-8")
    (studies / "two-trials.toml").write_text(TWO_TRIALS, encoding="utf-8")
    proc, base = start_server("contact-angle", extra=["--studies", str(studies)])
    try:
        yield LiveServer(base, base.replace("http://", "ws://") + "/ws")
    finally:
        stop_server(proc)


@pytest.fixture
def contexts(browser):
    require_web_deps()
    made = []

    def make(server: LiveServer, token=True, viewport=VIEWPORT, init: str | None = None):
        ctx = new_context(browser, server.http_url, token=token, viewport=viewport)
        if init:
            ctx.add_init_script(init)
        ctx.set_default_navigation_timeout(120_000)  # a loaded machine: these tests are about it
        ctx.set_default_timeout(30_000)
        made.append(ctx)
        return ctx.new_page()

    yield make
    for ctx in made:
        ctx.close()


@pytest.fixture
def sessions(rig):
    """new(study, participant) -> session; its running trial is aborted afterwards (the rig runs one
    trial at a time, across sessions)."""
    made = []

    def new(study: str, participant: str) -> dict:
        made.append(new_session(rig, study, participant))
        return made[-1]

    yield new
    get_json(f"{rig.http_url}/api/lease", "POST")  # aborting needs the lease
    for s in made:
        running = session_view(rig, s["id"])["running"]
        if running is not None:
            call(rig, "POST", f"/api/sessions/{s['id']}/trials/{running}/abort", {"reason": "test over"},
                 control=s["token"])


@pytest.fixture
def lease_back(rig):
    """The harness's admin holds the lease again after the test (tests release it)."""
    yield
    get_json(f"{rig.http_url}/api/lease", "POST")


def call(server: LiveServer, method: str, path: str, body: dict | None = None, control: str | None = None):
    """(status, answer) of a REST call as the harness's admin (with a session's control token)."""
    import json
    import urllib.error
    import urllib.request

    from tests.live_server import auth_headers

    headers = {"Content-Type": "application/json", **auth_headers(server.http_url)}
    if control:
        headers["X-Control-Token"] = control
    data = json.dumps(body).encode() if body is not None else None
    request = urllib.request.Request(server.http_url + path, data=data, method=method, headers=headers)
    try:
        with urllib.request.urlopen(request, timeout=20) as response:
            return response.status, json.loads(response.read())
    except urllib.error.HTTPError as exc:
        return exc.code, json.loads(exc.read())


def new_session(server: LiveServer, study: str, participant: str) -> dict:
    status, session = call(server, "POST", "/api/sessions", {"study": study, "participant": participant,
                                                             "experimenter": "alice"})
    assert status == 201, session
    return session


def join_url(server: LiveServer, session_id: str) -> str:
    """A join link for the session (it opens the session for its participant); the part after the host."""
    link = get_json(f"{server.http_url}/api/join-links", "POST", body={"session_id": session_id})
    return link["url"].split(server.http_url + "/", 1)[1]


def shot(page, name: str) -> None:
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / f"pages-{name}.png"))


# ---- point 1: pages always admit ----------------------------------------------------------------

def test_pages_with_a_slow_hello_are_admitted(contexts, rig):
    participant = Client(contexts(rig, init=SLOW_HELLO), rig).open()
    assert participant.hook("connection.status") == "ready"
    assert participant.page.is_hidden("#waiting")

    # the console's own live socket and its participant's view (an observer page in an iframe)
    page = contexts(rig, viewport={"width": 1440, "height": 900}, init=SLOW_HELLO)
    console = Console(page, rig).open()
    console.wait_text("#live-status", "live", timeout_ms=READY_TIMEOUT_MS)
    frame = page.frame_locator("#scene-frame")
    frame.locator("body").wait_for()
    view = page.frames[1]
    view.wait_for_function("window.__viestac && window.__viestac.clientId !== null", timeout=READY_TIMEOUT_MS)
    assert view.evaluate("document.getElementById('waiting').hidden"), view.evaluate(
        "document.getElementById('waiting').textContent")
    shot(page, "console-slow-hello")
    assert not participant.page_errors and not console.page_errors


def test_a_page_whose_hello_never_came_connects_again_by_itself(contexts, rig):
    page = contexts(rig, init=LOST_FIRST_HELLO)
    page.goto(f"{rig.http_url}/?role=participant")
    page.wait_for_function("window.__viestac && window.__viestac.connection")
    page.evaluate("""() => { const c = window.__viestac.connection; const seen = window.__statuses = [];
        const before = c.onStatus; c.onStatus = (s, d) => { seen.push(s); before(s, d); }; }""")
    # the server refuses the silent socket after its grace period; the page tries again, and is in
    page.wait_for_function("window.__viestac.clientId !== null", timeout=30_000)
    statuses = page.evaluate("window.__statuses")
    assert "reconnecting" in statuses and statuses[-1] == "ready", statuses
    assert page.is_hidden("#waiting")
    assert "not admitted" not in page.inner_text("body")


def test_the_participant_view_never_freezes_on_a_stale_frame(contexts, rig):
    """The console's participant view (an observer page): a socket that stays open but goes silent
    shows "reconnecting", is dropped, and the page is live again on a new one."""
    page = contexts(rig)
    sockets = []
    silent = {"on": False}

    def route(ws):
        first = not sockets
        server = ws.connect_to_server()
        server.on_message(lambda m: None if silent["on"] and first else ws.send(m))
        sockets.append(ws)

    page.route_web_socket("**/ws", route)
    view = Client(page, rig).open("?role=observer")
    frames = view.hook("stats.framesReceived")
    wait_for(lambda: view.hook("stats.framesReceived") > frames, what="state frames")
    silent["on"] = True  # the first socket stays open but nothing comes through any more
    page.wait_for_function("document.getElementById('waiting').innerText.includes('reconnecting')",
                           timeout=10_000)
    shot(page, "observer-stale")
    wait_for(lambda: (page.wait_for_timeout(100), len(sockets) >= 2)[1], timeout=30, what="a new connection")
    page.wait_for_function("document.getElementById('waiting').hidden", timeout=20_000)
    frames = view.hook("stats.framesReceived")
    wait_for(lambda: view.hook("stats.framesReceived") > frames, what="state frames on the new connection")


# ---- points 2 and 9: one clear state on the participant's page ----------------------------------

def test_a_participant_whose_session_closes_mid_trial_sees_one_state(contexts, rig, lease_back, sessions):
    session = sessions("xr-answers", "P21")
    sid, control = session["id"], session["token"]
    page = contexts(rig, token=None)
    participant = Client(page, rig).open(join_url(rig, sid))
    assert participant.hook("identity")["session"] == sid
    # nothing asked yet: the answer row is hidden for real (no empty dark pill)
    assert page.is_hidden("#answer"), page.locator("#answer").bounding_box()
    assert page.is_hidden("#waiting")

    status, _ = call(rig, "POST", f"/api/sessions/{sid}/trials/0/start", control=control)
    assert status == 200
    page.wait_for_selector("#answer:not([hidden])")
    page.wait_for_function("document.getElementById('answer').innerText.includes('How sharp')")
    shot(page, "participant-question")

    # the experimenter releases the lease mid-trial: the running trial stays the participant's (no
    # silent lockout): the question stays, nothing says "waiting", its pointer is not refused
    get_json(f"{rig.http_url}/api/lease", "DELETE")
    x, y = participant.screen((0.0, 0.2, 0.9))
    for k in range(20):
        page.mouse.move(x + k, y, steps=2)
        page.wait_for_timeout(50)
    page.wait_for_timeout(1500)
    assert page.is_hidden("#waiting"), page.inner_text("#waiting")
    assert page.is_visible("#answer")
    assert "forbidden" not in page.inner_text("#status")

    # the trial is aborted with nobody holding the lease: the session is closed now, and the page
    # says so in one state (no question beside it)
    status, _ = call(rig, "POST", f"/api/sessions/{sid}/trials/0/abort", {"reason": "test"}, control=control)
    assert status == 200
    page.wait_for_selector("#waiting:not([hidden])", timeout=10_000)
    assert "Waiting for the experimenter" in page.inner_text("#waiting")
    page.wait_for_function("document.getElementById('answer').hidden", timeout=5000)
    assert page.is_hidden("#answer") and page.is_hidden("#hud")
    for k in range(20):  # its pointer is refused meanwhile (forbidden): the status bar says so
        page.mouse.move(x + k, y, steps=2)
        page.wait_for_timeout(50)
    page.wait_for_function("document.getElementById('status').innerText.includes('forbidden')", timeout=10_000)
    shot(page, "participant-session-closed")

    # the lease back and the session opened again: the page is live, the old refusal gone
    get_json(f"{rig.http_url}/api/lease", "POST")
    join_url(rig, sid)
    page.wait_for_selector("#waiting", state="hidden", timeout=10_000)
    page.wait_for_function("!document.getElementById('status').innerText.includes('forbidden')", timeout=5000)
    shot(page, "participant-session-reopened")
    assert not participant.page_errors


# ---- point 3: a second tab of the session takes it; the first says so and only watches -----------

def test_a_second_tab_takes_the_session_and_the_first_says_so(contexts, rig, sessions):
    session = sessions("xr-answers", "P23")
    first_page = contexts(rig, token=None)
    first = Client(first_page, rig).open(join_url(rig, session["id"]))
    assert first.hook("connection.canSend") is True
    # the same participant opens the page again in another tab (a duplicated tab: the browser copies
    # the tab's sessionStorage, where the join token lives)
    token = first_page.evaluate("sessionStorage.getItem('viestac.join.token')")
    assert token
    second_page = first_page.context.new_page()
    second_page.add_init_script(f"sessionStorage.setItem('viestac.join.token', {token!r});")
    second = Client(second_page, rig).open()
    assert second.hook("identity")["session"] == session["id"]
    first_page.wait_for_function(
        "document.getElementById('waiting').innerText.includes('opened in another tab')", timeout=15_000)
    assert first_page.evaluate("window.__viestac.connection.sendTracker([0, 0.2, 0.9])") is False
    assert first.hook("connection.isOpen") is True  # it stays open and watches: no reconnect war
    assert second.hook("connection.canSend") is True and second_page.is_hidden("#waiting")
    clients = get_json(f"{rig.http_url}/api/clients")
    mine = [c for c in (clients["clients"] if isinstance(clients, dict) else clients)
            if c.get("session") == session["id"]]
    assert len(mine) == 2 and sum(1 for c in mine if c.get("replaced_by") is not None) == 1, mine
    shot(first_page, "participant-taken")
    assert not first.page_errors and not second.page_errors


# ---- points 2 and 8: the lease card ---------------------------------------------------------------

def test_the_lease_card_stays_put_and_warns_before_closing_a_session_mid_trial(contexts, rig, lease_back, sessions):
    session = sessions("xr-answers", "P22")
    sid, control = session["id"], session["token"]
    join_url(rig, sid)  # the participant session is open
    page = contexts(rig, viewport={"width": 1440, "height": 900})
    console = Console(page, rig).open(f"#session={sid}")
    page.wait_for_selector("#lease-release")
    status, _ = call(rig, "POST", f"/api/sessions/{sid}/trials/0/start", control=control)
    assert status == 200
    console.wait_state("s.running === 0")

    # 5 s of lease polls, lease messages and the running clock: the card and the run box stay put
    page.evaluate("""() => {
        window.__release = document.getElementById('lease-release');
        window.__runFirst = document.getElementById('run-now').firstElementChild;
        window.__removed = 0;
        new MutationObserver((ms) => { for (const m of ms) for (const n of m.removedNodes)
          if (n.nodeType === 1) window.__removed++; }).observe(document.getElementById('lease'),
          { childList: true, subtree: true });
    }""")
    page.wait_for_timeout(5000)
    assert page.evaluate("window.__removed") == 0
    assert page.evaluate("document.getElementById('lease-release') === window.__release")
    assert page.evaluate("document.getElementById('run-now').firstElementChild === window.__runFirst")

    # Release would close the participant's session mid-trial: asked first; "cancel" keeps the lease
    dialogs = []

    def answer(d, accept):
        dialogs.append(d.message)
        d.accept() if accept else d.dismiss()

    page.once("dialog", lambda d: answer(d, False))
    page.click("#lease-release")
    wait_for(lambda: dialogs, what="the release warning")
    assert f"closes participant session {sid}" in dialogs[0] and "trial #0" in dialogs[0], dialogs
    page.wait_for_timeout(500)
    assert get_json(f"{rig.http_url}/api/lease")["session"] == sid

    page.once("dialog", lambda d: answer(d, True))
    page.click("#lease-release")
    page.wait_for_selector("#lease-warning", timeout=10_000)
    assert "was closed while trial #0 runs" in page.inner_text("#lease-warning")
    page.locator("#lease-card").screenshot(path=str(ARTIFACTS / "pages-lease-warning.png"))
    assert not console.page_errors


# ---- point 9: the console's messages and buttons, participant codes, the live view -------------

def test_console_messages_and_buttons_follow_the_server(contexts, rig):
    page = contexts(rig, viewport={"width": 1400, "height": 900}, init=SLOW_SESSION_GET)
    console = Console(page, rig).open()
    # a participant code is a pseudonymous code with a digit: "Anna" is refused as "Anna Schmidt" is
    page.fill("#experimenter", "alice")
    page.select_option("#study", "two-trials")
    for name in ("Anna Schmidt", "Anna"):
        page.fill("#participant", name)
        page.click("#create")
        console.wait_text("#create-msg", "must not be a name")
        assert "at least one digit" in console.text("#create-msg")
        say = console.text("#create-msg")
        page.evaluate("document.getElementById('create-msg').textContent = ''")
    status, answer = call(rig, "POST", "/api/sessions", {"study": "two-trials", "participant": "Anna",
                                                         "experimenter": "alice"})
    assert status == 422 and "at least one digit" in answer["detail"], answer
    assert "at least one digit" in say
    page.fill("#participant", "P23")
    page.click("#create")
    console.wait_state("s.sessionId && s.control === 'yes' && s.next === 0")
    sid = console.state()["sessionId"]

    # the Experimenter field is whole at 1400 px
    box = page.locator("#experimenter").bounding_box()
    assert box and box["x"] >= 0 and box["x"] + box["width"] <= 1400, box
    # the participant's view: the scenario's debug text does not cover its HUD text
    view = page.frame(url=lambda u: "role=observer" in u)
    view.wait_for_function("window.__viestac && window.__viestac.ready", timeout=READY_TIMEOUT_MS)
    # the layout with a question and a few lines of values, whatever the scene says right now
    view.evaluate("""() => { const hud = document.getElementById('hud');
        hud.hidden = false; hud.textContent = 'Trial 4: which angle do you feel?';
        document.getElementById('values').textContent = 'angle_deg 10 · magnitude_pct 100 · probe hip · contact no';
        document.getElementById('events').textContent = 'tap 1\\ntap 2\\ntap 3'; }""")
    hud = view.locator("#hud").bounding_box()
    side = view.locator(".side").bounding_box()
    assert hud and side
    overlap = not (hud["x"] + hud["width"] <= side["x"] or side["x"] + side["width"] <= hud["x"]
                   or hud["y"] + hud["height"] <= side["y"] or side["y"] + side["height"] <= hud["y"])
    assert not overlap, (hud, side)
    page.screenshot(path=str(ARTIFACTS / "pages-console-1400.png"))

    # trial 0: a note saved ("Saved 1 answer."), then finished while the server answers slowly
    page.wait_for_selector("#start:not([disabled])")
    page.click("#start")
    try:
        wait_for(lambda: session_view(rig, sid)["trials"][0]["status"] == "running", timeout=30, what="trial 0 running")
    except AssertionError as exc:
        raise AssertionError(f"{exc}; the console says {console.text('#run-msg')!r}") from None
    note = page.locator('fieldset[data-question="note"] textarea, fieldset[data-question="note"] input')
    note.first.wait_for()
    note.first.fill("fine")
    page.click("#save-answers")
    console.wait_text("#answers-msg", "Saved 1 answer")
    page.evaluate("""() => {
        window.__slowSessionMs = 1500;
        window.__atOk = null;
        new MutationObserver(() => {
          const t = document.getElementById('run-msg').innerText;
          if (window.__atOk === null && t.includes('finished')) window.__atOk = {
            finishDisabled: document.getElementById('finish').disabled,
            runNow: document.getElementById('run-now').innerText };
        }).observe(document.getElementById('run-msg'), { childList: true, characterData: true, subtree: true });
    }""")
    page.click("#finish")
    page.wait_for_function("window.__atOk !== null", timeout=20_000)
    at_ok = page.evaluate("window.__atOk")
    assert at_ok["finishDisabled"] and "running" not in at_ok["runNow"], at_ok
    assert session_view(rig, sid)["trials"][0]["status"] == "answered"
    page.evaluate("window.__slowSessionMs = 0")

    # the next trial does not show the last one's "Saved 1 answer."
    page.click("#start")
    wait_status(rig, sid, 1, "running")
    console.wait_state("s.running === 1 && s.selected === 1")
    page.wait_for_timeout(300)
    assert "Saved" not in console.text("#answers-msg")
    assert not console.page_errors
