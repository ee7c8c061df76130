"""Headless Chromium against a running server: a page of another site (evil.example, resolved to
this machine by --host-resolver-rules) cannot open /ws nor read the API, and a rebinding page
(evil.example resolved to the server itself) gets 400; the server's own page can. HTTPS and WSS
work with a `viestac tls init` certificate (Chromium trusts its key by SPKI pin)."""

from __future__ import annotations

import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

from server import tls
from tests.browser.conftest import CHROMIUM, CHROMIUM_ARGS

pytestmark = [pytest.mark.browser, pytest.mark.slow]

OPEN_WS = """url => new Promise(resolve => {
  const ws = new WebSocket(url);
  ws.onopen = () => { ws.close(); resolve('open'); };
  ws.onerror = () => resolve('error');
  setTimeout(() => resolve('timeout'), 8000);
})"""
READ = "url => fetch(url).then(r => 'read ' + r.status, () => 'blocked')"


class EvilPage(BaseHTTPRequestHandler):
    def do_GET(self):  # noqa: N802 (http.server's name)
        body = b"<!doctype html><title>another site</title>"
        self.send_response(200)
        self.send_header("Content-Type", "text/html")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, *args):
        pass


@pytest.fixture(scope="module")
def evil_site():
    server = ThreadingHTTPServer(("127.0.0.1", 0), EvilPage)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield server.server_address[1]
    server.shutdown()


@pytest.fixture(scope="module")
def chromium(tls_files):
    if not CHROMIUM.exists():
        pytest.skip(f"{CHROMIUM} is missing (apt-get install chromium); browser tests need it")
    sync_api = pytest.importorskip("playwright.sync_api")
    args = [*CHROMIUM_ARGS, "--host-resolver-rules=MAP evil.example 127.0.0.1",
            f"--ignore-certificate-errors-spki-list={tls.spki_sha256(tls_files.path('cert'))}"]
    with sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=str(CHROMIUM), args=args)
        try:
            yield browser
        finally:
            browser.close()


@pytest.fixture
def page(chromium):
    context = chromium.new_context()
    yield context.new_page()
    context.close()


def test_another_sites_page_cannot_open_the_websocket_or_read_the_api(page, http_server, evil_site):
    page.goto(f"http://evil.example:{evil_site}/")
    ws = f"ws://127.0.0.1:{http_server.port}/ws"
    assert page.evaluate(OPEN_WS, ws) == "error"
    assert page.evaluate(READ, f"{http_server.base}/api/health") == "blocked"  # no CORS headers


def test_the_servers_own_page_opens_the_websocket(page, http_server):
    assert page.goto(f"{http_server.base}/style.css").status == 200
    assert page.evaluate(OPEN_WS, f"ws://127.0.0.1:{http_server.port}/ws") == "open"


def test_a_rebinding_page_gets_400(page, http_server):
    """evil.example now resolves to the rig (DNS rebinding): the server still refuses its Host."""
    response = page.goto(f"http://evil.example:{http_server.port}/")
    assert response.status == 400
    assert page.evaluate(OPEN_WS, f"ws://evil.example:{http_server.port}/ws") == "error"


def test_https_and_wss_with_a_tls_init_certificate(page, https_server):
    response = page.goto(f"https://localhost:{https_server.port}/style.css")
    assert response.status == 200
    assert page.evaluate("window.isSecureContext") is True  # what WebXR needs on a headset
    assert page.evaluate(OPEN_WS, f"wss://localhost:{https_server.port}/ws") == "open"
    assert page.evaluate(READ, f"https://localhost:{https_server.port}/index.html") == "read 200"


@pytest.mark.parametrize("path", ["/index.html", "/console.html"])
def test_the_pages_run_under_the_content_security_policy(page, http_server, path):
    """The import maps are allowed by hash and the console may frame the participant page: no
    violation is reported (a new inline script in a page would be one)."""
    messages: list[str] = []
    page.on("console", lambda m: messages.append(m.text))
    page.on("pageerror", lambda e: messages.append(f"pageerror {e}"))
    assert page.goto(http_server.base + path).status == 200
    page.wait_for_timeout(2000)
    assert not [m for m in messages if "Content Security Policy" in m or "Refused to" in m], messages
    if path == "/console.html" and page.locator("iframe").count():
        assert len(page.frames) > 1 and not page.frames[1].url.startswith("chrome-error")
