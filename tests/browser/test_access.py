"""Access in the browser (issue 19, docs/security.md), against a server of its own whose lease the
harness's admin does not take: the console's log-in screen and a login link, the lease card with
two experimenters of two sites (queue, hand over, release, an admin's force release), a
participant join link with its QR code opened in a second browser, and the participant's
"waiting for the experimenter" state. Screenshots: tests/artifacts/browser/access-*.png.
"""

from __future__ import annotations

import pytest

from tests.live_server import admin_token, get_json, start_server, stop_server
from tests.browser.conftest import ARTIFACTS, new_context, require_web_deps
from tests.browser.test_console import CONSOLE_VIEWPORT, Console
from tests.browser.test_web_client import READY_TIMEOUT_MS, VIEWPORT, Client, wait_tracker
from tests.live_server import LiveServer

pytestmark = pytest.mark.browser


@pytest.fixture(scope="module")
def rig():
    """A server nobody holds the lease of; `.data_dir` is its access store's directory."""
    proc, base = start_server("contact-angle", take_lease=False)
    try:
        server = LiveServer(base, base.replace("http://", "ws://") + "/ws")
        server.data_dir = proc.own_data_dir
        yield server
    finally:
        stop_server(proc)


@pytest.fixture
def contexts(browser):
    require_web_deps()
    made = []

    def make(server: LiveServer, token=None, viewport=CONSOLE_VIEWPORT):
        ctx = new_context(browser, server.http_url, token=token, viewport=viewport)
        made.append(ctx)
        return ctx.new_page()

    yield make
    for ctx in made:
        ctx.close()


@pytest.fixture
def free_lease(rig):
    """Nobody holds or waits for the lease before and after the test."""
    get_json(f"{rig.http_url}/api/lease/force-release", "POST")
    yield
    for _ in range(5):  # the queue moves up on each force release
        if not get_json(f"{rig.http_url}/api/lease/force-release", "POST")["released"]:
            break


def experimenter(server: LiveServer, site: str, label: str) -> str:
    """A new experimenter token of `site` (made by the admin over REST)."""
    answer = get_json(f"{server.http_url}/api/tokens", "POST",
                      body={"role": "experimenter", "site": site, "label": label, "ttl_s": 3600})
    return answer["token"]


def login_code(server: LiveServer) -> str:
    """A fresh single-use login code, written to the server's access store as the CLI does."""
    from server.auth import open_book

    store, book = open_book(server.data_dir)
    try:
        return book.create_code("login", role="admin", ttl_s=600)
    finally:
        store.close()


def open_console(page, server: LiveServer, fragment: str = "") -> Console:
    return Console(page, server).open(fragment)


def lease(console: Console) -> dict:
    return console.page.evaluate("window.__console.lease()")


def wait_lease(console: Console, js_condition: str, timeout_ms: int = 10_000) -> None:
    console.page.wait_for_function(f"(() => {{ const l = window.__console.lease(); return {js_condition}; }})()",
                                   timeout=timeout_ms)


def test_login_screen_and_login_link(contexts, rig):
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    # no token: the log-in screen, and nothing of the rig
    page = contexts(rig)
    console = open_console(page, rig)
    page.wait_for_selector("#login:not([hidden])")
    assert console.text("#identity") == "not logged in"
    page.screenshot(path=str(ARTIFACTS / "access-login-screen.png"))

    # a wrong token is refused in words; the screen stays
    page.fill("#login-token", "not-a-token")
    page.click("#login-submit")
    console.wait_text("#login-msg", "not valid")
    assert page.is_visible("#login")

    # a login link: exchanged at once, gone from the address bar, the console is the admin's
    code = login_code(rig)
    page2 = contexts(rig)
    console2 = open_console(page2, rig, f"#login={code}")
    page2.wait_for_function("window.__console.identity()?.role === 'admin'", timeout=READY_TIMEOUT_MS)
    assert "login=" not in page2.url and code not in page2.url
    assert page2.is_hidden("#login")
    token = page2.evaluate("localStorage.getItem('viestac.token')")
    assert token and token != code and token != admin_token(rig.http_url)
    assert get_json(f"{rig.http_url}/api/auth/me", token=token)["role"] == "admin"
    console2.wait_text("#identity", "admin")
    assert page2.locator("#study option").count() >= 1  # the studies load once logged in

    # the same link a second time is used up: the log-in screen says so
    page3 = contexts(rig)
    open_console(page3, rig, f"#login={code}")
    page3.wait_for_selector("#login:not([hidden])")
    Console(page3, rig).wait_text("#login-why", "not valid any more")
    assert "login=" not in page3.url

    # pasting a token logs in too; log out forgets it
    exp = experimenter(rig, "lab-a", "carol")
    page.fill("#login-token", exp)
    page.click("#login-submit")
    page.wait_for_function("window.__console.identity()?.role === 'experimenter'")
    console.wait_text("#identity", "carol")
    assert "site lab-a" in console.text("#identity")
    page.click("#logout")
    page.wait_for_selector("#login:not([hidden])")
    assert page.evaluate("localStorage.getItem('viestac.token')") is None
    assert not console.page_errors and not console2.page_errors


def test_lease_card_with_two_experimenters(contexts, rig, free_lease):
    a = open_console(contexts(rig, experimenter(rig, "lab-a", "alice")), rig)
    b = open_console(contexts(rig, experimenter(rig, "lab-b", "bob")), rig)
    wait_lease(a, "l.holder === null && l.actions.request")

    a.click("#lease-request")
    wait_lease(a, "l.you === 'holder'")
    a.wait_text("#lease-summary", "You control the rig")
    wait_lease(b, "l.holder && l.holder.who.startsWith('alice')")
    b.click("#lease-request")
    wait_lease(b, "l.you === 'queued' && l.position === 1")
    b.wait_text("#lease-msg", "Queued: you are #1")
    b.wait_text("#lease-summary", "alice")
    assert "you are #1 in the queue" in b.text("#lease-summary")
    # the holder sees bob waiting and may hand over; bob may only leave the queue
    wait_lease(a, "l.queue.length === 1 && l.queue[0].who.startsWith('bob')")
    a.page.wait_for_selector("#lease-queue button")
    assert b.page.locator("#lease-queue button").count() == 0 and b.page.is_visible("#lease-leave")
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    a.page.screenshot(path=str(ARTIFACTS / "access-lease-holder.png"), full_page=True)
    b.page.screenshot(path=str(ARTIFACTS / "access-lease-queued.png"), full_page=True)

    # hand over: bob holds it, alice is out
    a.page.click("#lease-queue button")
    wait_lease(b, "l.you === 'holder'")
    wait_lease(a, "l.you === 'none' && l.holder.who.startsWith('bob')")
    assert get_json(f"{rig.http_url}/api/lease")["holder"]["label"] == "bob"

    # alice queues again; bob releases: the queue moves up
    a.click("#lease-request")
    wait_lease(a, "l.you === 'queued'")
    b.click("#lease-release")
    wait_lease(a, "l.you === 'holder'")
    wait_lease(b, "l.you === 'none'")

    # an admin may take it away by force (after a confirmation)
    admin = open_console(contexts(rig, True), rig)
    wait_lease(admin, "l.actions.forceRelease")
    admin.page.on("dialog", lambda d: d.accept())
    admin.click("#lease-force")
    wait_lease(a, "l.holder === null")
    admin.wait_text("#lease-msg", "released by force")
    assert not a.page_errors and not b.page_errors and not admin.page_errors


def test_join_link_flow(contexts, rig, free_lease):
    exp = experimenter(rig, "lab-a", "dana")
    console = open_console(contexts(rig, exp), rig)
    page = console.page
    assert page.is_disabled("#join-create")  # not the holder yet
    page.click("#lease-request")
    wait_lease(console, "l.you === 'holder'")
    page.wait_for_selector("#join-create:not([disabled])")
    page.click("#join-create")
    page.wait_for_selector("#join-qr svg")
    url = page.input_value("#join-url")
    assert "#join=" in url and "role=participant" in url
    session = page.evaluate("window.__console.join().session")
    assert session.startswith("free-")
    wait_lease(console, f"l.session === {session!r}")
    box = page.locator("#join-qr svg").bounding_box()
    assert box["width"] >= 150 and box["height"] >= 150
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page.locator("#join-card").screenshot(path=str(ARTIFACTS / "access-join-link.png"))

    # the participant's browser (no token of its own) opens the link: joined, code gone from the bar
    participant_page = contexts(rig, None, VIEWPORT)
    participant = Client(participant_page, rig).open(url.split(rig.http_url + "/", 1)[1])
    assert "#join" not in participant_page.url
    assert participant_page.evaluate("sessionStorage.getItem('viestac.join.token')")
    assert participant_page.evaluate("localStorage.getItem('viestac.token')") is None
    identity = participant.hook("identity")
    assert identity["role"] == "participant" and identity["session"] == session
    assert participant.page.is_hidden("#waiting")
    # it drives the HIP
    cid = participant.client_id
    x, y = participant.screen((0.0, 0.2, 0.9))
    participant_page.mouse.move(x, y, steps=4)
    wait_tracker(rig, cid, timeout=10)
    participant_page.screenshot(path=str(ARTIFACTS / "access-participant-joined.png"))

    # the experimenter releases the lease: the participant waits for the experimenter
    page.click("#lease-release")
    participant_page.wait_for_selector("#waiting:not([hidden])", timeout=10_000)
    assert "Waiting for the experimenter" in participant_page.inner_text("#waiting")
    participant_page.screenshot(path=str(ARTIFACTS / "access-participant-waiting.png"))

    # the same link again: used up
    again = contexts(rig, None, VIEWPORT)
    again.goto(url)
    again.wait_for_selector("#waiting:not([hidden])", timeout=READY_TIMEOUT_MS)
    assert "not valid any more" in again.inner_text("#waiting")
    assert not console.page_errors and not participant.page_errors
