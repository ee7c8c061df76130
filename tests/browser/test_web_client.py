"""The browser client (clients/web) in headless Chromium against a live server.

Needs the `live_server` fixture (tests/conftest.py): a real server on an ephemeral port running
the contact-angle scenario, with `http_url` and `ws_url`. Chromium is Debian's /usr/bin/chromium
rendering WebGL through SwiftShader; Playwright downloads no browser.
"""

from __future__ import annotations

import base64
import json
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.browser

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless=new",
    "--no-sandbox",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]
VIEWPORT = {"width": 1024, "height": 768}
ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "tests" / "artifacts" / "browser"
WEB_DEPS = [ROOT / "clients/web/node_modules/three/build/three.module.js",
            ROOT / "clients/web/node_modules/@msgpack/msgpack/dist.esm/index.mjs"]
READY_TIMEOUT_MS = 20_000


# -- fixtures ---------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def browser():
    if not CHROMIUM.exists():
        pytest.skip(f"{CHROMIUM} is missing (apt-get install chromium); browser tests need it")
    missing = [str(p.relative_to(ROOT)) for p in WEB_DEPS if not p.exists()]
    assert not missing, f"web client dependencies missing ({missing}): run `cd clients/web && npm ci`"
    sync_api = pytest.importorskip("playwright.sync_api")
    with sync_api.sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        try:
            yield b
        finally:
            b.close()


class Client:
    """One browser page running the web client, plus what it logged."""

    def __init__(self, page, server):
        self.page = page
        self.server = server
        self.page_errors: list[str] = []
        self.console_errors: list[str] = []
        page.on("pageerror", lambda e: self.page_errors.append(str(e)))
        page.on("console", lambda m: m.type == "error" and self.console_errors.append(m.text))

    def open(self, query: str = "") -> "Client":
        self.page.goto(f"{self.server.http_url}/{query}")
        self.page.wait_for_function(
            "window.__viestac && window.__viestac.ready && window.__viestac.clientId !== null",
            timeout=READY_TIMEOUT_MS,
        )
        return self

    def hook(self, expr: str):
        return self.page.evaluate(f"window.__viestac.{expr}")

    @property
    def client_id(self) -> int:
        return self.hook("clientId")

    def graph(self) -> dict[str, dict]:
        return {o["id"]: o for o in self.hook("sceneGraph()")}

    def screen(self, scene_pos) -> tuple[float, float]:
        p = self.page.evaluate("(p) => window.__viestac.screenPosition(p)", list(scene_pos))
        return p["x"], p["y"]


@pytest.fixture
def open_client(browser, live_server):
    contexts = []

    def make(query: str = "") -> Client:
        ctx = browser.new_context(viewport=VIEWPORT)
        contexts.append(ctx)
        return Client(ctx.new_page(), live_server).open(query)

    yield make
    for ctx in contexts:
        ctx.close()


# -- helpers ----------------------------------------------------------------------------------


def api_clients(server) -> list[dict]:
    with urllib.request.urlopen(f"{server.http_url}/api/clients", timeout=5) as r:
        return json.load(r)


def server_view(server, client_id: int) -> dict | None:
    for c in api_clients(server):
        if c["client_id"] == client_id:
            return c
    return None


def wait_for(predicate, timeout=5.0, interval=0.05, what="condition"):
    deadline = time.monotonic() + timeout
    last = None
    while time.monotonic() < deadline:
        last = predicate()
        if last:
            return last
        time.sleep(interval)
    raise AssertionError(f"timed out after {timeout} s waiting for {what} (last: {last!r})")


def wait_tracker(server, client_id: int, expect=None, timeout=5.0) -> dict:
    """The server's view of this client once it holds a tracker sample (equal to `expect`, if given)."""

    def probe():
        c = server_view(server, client_id)
        if not c or not c["tracker_count"] or c["last_tracker"] is None:
            return None
        if expect is not None and not np.allclose(c["last_tracker"]["pos"], expect, rtol=0, atol=1e-9):
            return None
        return c

    what = f"tracker sample {expect} from client {client_id}" if expect else f"a tracker sample from {client_id}"
    return wait_for(probe, timeout, what=what)


def settled_position(client: Client, server) -> list[float]:
    """Wait for the client's current HIP target to reach the server; return it (scene frame)."""
    target = client.hook("hipTarget()")
    assert target is not None, "the client has no pointer position"
    return wait_tracker(server, client.client_id, expect=target)["last_tracker"]["pos"]


def screenshot_pixels(page, png: bytes) -> np.ndarray:
    """Decode a PNG screenshot with the browser itself (no imaging library needed): H×W×4 uint8."""
    data = page.evaluate(
        """async (b64) => {
            const img = new Image();
            img.src = 'data:image/png;base64,' + b64;
            await img.decode();
            const c = document.createElement('canvas');
            c.width = img.naturalWidth; c.height = img.naturalHeight;
            const g = c.getContext('2d');
            g.drawImage(img, 0, 0);
            const px = g.getImageData(0, 0, c.width, c.height).data;
            let s = '';
            for (let i = 0; i < px.length; i += 0x8000) s += String.fromCharCode(...px.subarray(i, i + 0x8000));
            return {w: c.width, h: c.height, b64: btoa(s)};
        }""",
        base64.b64encode(png).decode(),
    )
    return np.frombuffer(base64.b64decode(data["b64"]), np.uint8).reshape(data["h"], data["w"], 4)


def hex_rgb(color: str) -> np.ndarray:
    c = color.lstrip("#")
    return np.array([int(c[i : i + 2], 16) for i in (0, 2, 4)], float)


def chroma(rgb) -> np.ndarray:
    rgb = np.asarray(rgb, float)
    return rgb / max(rgb.sum(), 1.0)


# -- tests ------------------------------------------------------------------------------------


def test_contact_angle_scene_renders(open_client):
    client = open_client()
    page = client.page
    graph = client.graph()
    types = {o["type"] for o in graph.values()}
    assert "hemisphere" in types, graph
    assert "plane" in types, graph
    assert "hip" in graph and graph["hip"]["visible"], graph["hip"]
    hemi = next(o for o in graph.values() if o["type"] == "hemisphere")
    assert hemi["visible"]
    assert client.hook("renderer"), "no WebGL renderer string"

    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    shot = ARTIFACTS / "contact_angle.png"
    png = page.screenshot(path=str(shot))
    assert shot.stat().st_size > 0
    px = screenshot_pixels(page, png)[:, :, :3].astype(float)
    assert px.shape[:2] == (VIEWPORT["height"], VIEWPORT["width"])

    # Not blank: real variance and more than a handful of distinct colours.
    assert px.std() > 10, f"screenshot looks blank (std {px.std():.1f})"
    distinct = len(np.unique((px[::4, ::4] // 8).reshape(-1, 3), axis=0))
    assert distinct > 8, f"only {distinct} distinct colours"

    # The hemisphere's colour shows inside its outline: sample points on the dome's silhouette
    # disc (scene frame: centre + r/2 up, and ±r/2 sideways at r/3 up).
    r = hemi["shape"]["radius"]
    cx, cy, cz = hemi["position"][2], hemi["position"][0], hemi["position"][1]  # three → scene
    want = chroma(hex_rgb(hemi["color"]))
    background = px[5, 5]
    hits = 0
    samples = [(cx, cy, cz + r / 2), (cx, cy - r / 2, cz + r / 3), (cx, cy + r / 2, cz + r / 3),
               (cx, cy, cz + r / 4), (cx, cy, cz + 3 * r / 4)]
    for p in samples:
        x, y = client.screen(p)
        patch = px[int(y) - 2 : int(y) + 3, int(x) - 2 : int(x) + 3].reshape(-1, 3).mean(axis=0)
        if np.abs(chroma(patch) - want).max() < 0.06 and np.abs(patch - background).max() > 20:
            hits += 1
    assert hits >= 4, f"hemisphere colour {hemi['color']} found at only {hits}/{len(samples)} sample points"
    assert not client.page_errors, client.page_errors


def test_state_frames_arrive(open_client):
    client = open_client()
    first = client.hook("stats.framesReceived")
    time.sleep(0.5)
    stats = client.hook("stats")
    assert stats["framesReceived"] > first, stats
    assert stats["lastStateFrame"] is not None
    assert stats["lastError"] is None, stats["lastError"]
    assert client.hook("renderer"), "no WebGL renderer string"
    assert not client.page_errors, client.page_errors


def test_pointer_and_wheel_drive_the_tracker(open_client, live_server):
    client = open_client()
    page = client.page
    cid = client.client_id
    assert server_view(live_server, cid)["role"] == "participant"

    w, h = VIEWPORT["width"], VIEWPORT["height"]
    page.mouse.move(w * 0.4, h * 0.5)
    for i in range(1, 11):  # sweep right in steps
        page.mouse.move(w * 0.4 + 20 * i, h * 0.5)
        page.wait_for_timeout(20)
    c = wait_tracker(live_server, cid)
    assert c["tracker_count"] > 0
    assert client.hook("stats.trackerSent") > 0
    p0 = settled_position(client, live_server)

    # further right → y grows, x and z stay
    page.mouse.move(w * 0.4 + 300, h * 0.5, steps=5)
    p1 = settled_position(client, live_server)
    assert p1[1] > p0[1] + 0.1, (p0, p1)
    assert p1[0] == pytest.approx(p0[0], abs=1e-9) and p1[2] == pytest.approx(p0[2], abs=1e-9), (p0, p1)

    # up → z grows, x and y stay
    page.mouse.move(w * 0.4 + 300, h * 0.5 - 150, steps=5)
    p2 = settled_position(client, live_server)
    assert p2[2] > p1[2] + 0.1, (p1, p2)
    assert p2[0] == pytest.approx(p1[0], abs=1e-9) and p2[1] == pytest.approx(p1[1], abs=1e-9), (p1, p2)

    # wheel → depth (scene x) changes by one step (0.02), the screen-plane position stays
    page.mouse.wheel(0, 100)
    wait_for(lambda: client.hook("depth()") != 0, what="the wheel to change the depth")
    p3 = settled_position(client, live_server)
    assert abs(p3[0] - p2[0]) == pytest.approx(0.02, abs=1e-9), (p2, p3)
    assert p3[1] == pytest.approx(p2[1], abs=1e-9) and p3[2] == pytest.approx(p2[2], abs=1e-9), (p2, p3)
    assert client.hook("stats.lastError") is None
    assert not client.page_errors, client.page_errors


def test_json_subprotocol(open_client, live_server):
    client = open_client("?format=json")
    assert server_view(live_server, client.client_id)["format"] == "json"
    n = client.hook("stats.framesReceived")
    wait_for(lambda: client.hook("stats.framesReceived") > n, what="state frames over JSON")
    client.page.mouse.move(500, 300)
    client.page.mouse.move(520, 310)
    assert wait_tracker(live_server, client.client_id)["tracker_count"] > 0
    assert client.hook("stats.lastError") is None


def test_observer_sends_no_tracker(open_client, live_server):
    client = open_client("?role=observer")
    assert client.hook("role") == "observer"
    client.page.mouse.move(500, 300)
    client.page.mouse.move(600, 320, steps=5)
    client.page.keyboard.press("r")
    client.page.wait_for_timeout(300)
    view = server_view(live_server, client.client_id)
    assert view is not None and view["role"] == "observer"
    assert view["tracker_count"] == 0
    assert client.hook("stats.trackerSent") == 0
    assert client.hook("stats.lastError") is None  # nothing was sent, so nothing was forbidden
