"""The browser client (clients/web) in headless Chromium against a live server.

Needs the `live_server` fixture (tests/conftest.py): a real server on an ephemeral port running
the contact-angle scenario, with `http_url` and `ws_url`. Chromium is Debian's /usr/bin/chromium
rendering WebGL through SwiftShader; Playwright downloads no browser. Tests that switch the
server's scenario put contact-angle back when they finish (`contact_angle_after`): the server is
shared by the whole session.
"""

from __future__ import annotations

import base64
import json
import time
import urllib.request

import numpy as np
import pytest

from tests.browser.conftest import ARTIFACTS, auth_header, new_context, require_web_deps
from tests.live_server import LiveServer, get_json, start_server, stop_server

pytestmark = pytest.mark.browser

VIEWPORT = {"width": 1024, "height": 768}
READY_TIMEOUT_MS = 20_000
REBUILD_TIMEOUT_MS = 15_000


# -- fixtures ---------------------------------------------------------------------------------


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

    def wait_rebuilt(self, scene_hash: str) -> None:
        """Wait until the page has drawn the scene `scene_hash` with its skins loaded and one state
        frame of that scene applied (visibility overrides come with state frames)."""
        self.page.wait_for_function(
            """(h) => { const v = window.__viestac;
                return v.renderedHash === h && v.skins().pending === 0 && v.stats.lastStateFrame !== null; }""",
            arg=scene_hash, timeout=REBUILD_TIMEOUT_MS)
        frame = self.hook("stats.lastStateFrame")
        wait_for(lambda: self.hook("stats.lastStateFrame") > frame, what="a state frame of the new scene")
        self.frames_drawn(3)  # a few more frames drawn (counted, not timed: a loaded machine draws fewer)

    def frames_drawn(self, n: int) -> None:
        """Return once the page has drawn `n` more animation frames (its frame() runs in each)."""
        self.page.evaluate("""(n) => new Promise((resolve, reject) => {
            const giveUp = setTimeout(() => reject(new Error(`not ${n} frames drawn in 60 s`)), 60000);
            let k = 0;
            const step = () => { if (++k >= n) { clearTimeout(giveUp); resolve(); } else requestAnimationFrame(step); };
            requestAnimationFrame(step); })""", n)

    def settled_memory(self) -> dict:
        """The renderer's geometry and texture counts once drawing has settled: the same before and
        after a few more frames. three.js counts a geometry or texture when it first draws it (an
        object a state frame showed, a skin that finished loading), so a reading right after a
        rebuild depends on how many frames a loaded machine managed to draw; a leak stays."""
        def unchanged():
            before = self.hook("memory()")
            self.frames_drawn(3)
            return before if self.hook("memory()") == before else None
        return wait_for(unchanged, timeout=60, what="the page's geometry and texture counts to settle")


# requestAnimationFrame with a delay: a page on a loaded machine draws fewer frames per event
SLOW_FRAMES = """{ const raf = window.requestAnimationFrame.bind(window);
  window.requestAnimationFrame = (draw) => { setTimeout(() => raf(draw), %d); return 0; }; }"""


@pytest.fixture
def contact_angle_after(live_server):
    """Put the session's server back on contact-angle (default parameters) after the test."""
    yield
    switch_scenario(live_server, "contact-angle")


@pytest.fixture
def open_client(browser, live_server):
    require_web_deps()
    contexts = []

    def make(query: str = "", server: LiveServer | None = None, frame_every_ms: int = 0) -> Client:
        """`frame_every_ms`: the page draws at most one frame that often, as on a loaded machine."""
        server = server or live_server
        ctx = new_context(browser, server.http_url, viewport=VIEWPORT)
        if frame_every_ms:
            ctx.add_init_script(SLOW_FRAMES % frame_every_ms)
        contexts.append(ctx)
        return Client(ctx.new_page(), server).open(query)

    yield make
    for ctx in contexts:
        ctx.close()


# -- helpers ----------------------------------------------------------------------------------


def api_clients(server) -> list[dict]:
    req = urllib.request.Request(f"{server.http_url}/api/clients", headers=auth_header(server.http_url))
    with urllib.request.urlopen(req, timeout=5) as r:
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


def switch_scenario(server, name: str, params: dict | None = None) -> str:
    """POST /api/scenario (forced: the test rig's devices cannot show every dimension), wait until
    the loop runs it and return its scene hash. The loop publishes the scene before announcing
    the scenario, so once GET /api/scenario names it, GET /api/scene is the new scene."""
    answer = get_json(f"{server.http_url}/api/scenario", "POST",
                      body={"name": name, "params": params or {}, "seed": 0, "force": True})

    def running():
        now = server.get("/api/scenario")
        return now.get("id") == answer["id"] and now.get("params") == answer["params"]

    wait_for(running, timeout=10, what=f"the server to run {answer['id']}")
    return server.get("/api/scene")["hash"]


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
    wait_for(lambda: client.hook("stats.framesReceived") > first, what="a state frame after the first")
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


# -- scenarios, overlays, skins, operator panel -------------------------------------------------

SKIN = "/skins/stripes.svg"
SCENARIOS = [
    ("contact-angle-v1", {}),
    ("texture-v1", {"skin": SKIN}),
    ("stiffness-v1", {}),
    ("shape-v1", {}),
    ("friction-temperature-v1", {}),
    ("positioning-v1", {}),
    ("peg-in-hole-v1", {}),
    ("hot-wire-v1", {}),
    ("hot-wire-v1", {"path": "circle"}),
    ("hot-wire-v1", {"path": "spiral", "target_speed": 0.2}),
    ("pick-place-v1", {}),
]


def shot_name(scenario: str, params: dict) -> str:
    """The screenshot's (and the test's) name: the scenario, and the path for the hot wire's."""
    return f"{scenario}-{params['path']}" if "path" in params else scenario


def scene_of(three_pos) -> np.ndarray:
    """three.js (X, Y, Z) → scene (x, y, z) = (Z, X, Y)."""
    return np.array([three_pos[2], three_pos[0], three_pos[1]], float)


def probe_points(obj: dict) -> list[np.ndarray]:
    """Scene points inside an object's silhouette, seen from the front, for colour sampling."""
    c = scene_of(obj["position"])
    s = obj["shape"]
    if s["type"] == "sphere":
        r = s["radius"]
        offsets = [(0, 0, 0), (0, -r / 2, 0), (0, r / 2, 0), (0, 0, r / 2), (0, 0, -r / 2)]
    elif s["type"] == "box":
        _, sy, sz = s["size"]
        offsets = [(0, 0, 0), (0, -sy / 4, 0), (0, sy / 4, 0), (0, 0, sz / 4), (0, 0, -sz / 4)]
    elif s["type"] == "cone":
        r, h = s["radius"], s["height"]
        offsets = [(0, 0, h / 4), (0, -r / 3, h / 4), (0, r / 3, h / 4), (0, 0, h / 2), (0, 0, h / 8)]
    elif s["type"] == "hemisphere":
        r = s["radius"]
        offsets = [(0, 0, r / 2), (0, -r / 2, r / 3), (0, r / 2, r / 3), (0, 0, r / 4), (0, 0, 3 * r / 4)]
    else:
        return []
    return [c + np.array(o, float) for o in offsets]


def patch(px: np.ndarray, x: float, y: float, half: int = 2) -> np.ndarray:
    return px[int(y) - half : int(y) + half + 1, int(x) - half : int(x) + half + 1].reshape(-1, 3)


def shows_colour(px: np.ndarray, client: Client, obj: dict) -> int:
    """How many of an object's probe points show its colour (hue, and not the background)."""
    want = chroma(hex_rgb(obj["color"]))
    background = px[5, 5]
    hits = 0
    for p in probe_points(obj):
        mean = patch(px, *client.screen(p)).mean(axis=0)
        if np.abs(chroma(mean) - want).max() < 0.06 and np.abs(mean - background).max() > 20:
            hits += 1
    return hits


def label_drawn(px: np.ndarray, x: float, y: float) -> bool:
    """A label at (x, y): its light outline and its dark letters both show around there."""
    box = px[int(y) - 10 : int(y) + 11, int(x) - 14 : int(x) + 15].reshape(-1, 3)
    light = (box.min(axis=1) > 190).sum()
    dark = (box.max(axis=1) < 60).sum()
    return light >= 10 and dark >= 5


@pytest.mark.parametrize("scenario,params", SCENARIOS, ids=[shot_name(s, p) for s, p in SCENARIOS])
def test_scenario_screenshots(open_client, live_server, contact_angle_after, scenario, params):
    client = open_client()
    page = client.page
    scene_hash = switch_scenario(live_server, scenario, params)
    client.wait_rebuilt(scene_hash)
    assert client.hook("sceneHash") == scene_hash

    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    png = page.screenshot(path=str(ARTIFACTS / f"{shot_name(scenario, params)}.png"))
    px = screenshot_pixels(page, png)[:, :, :3].astype(float)
    w, h = VIEWPORT["width"], VIEWPORT["height"]

    graph = client.graph()
    scene = live_server.get("/api/scene")["scene"]
    assert {o["id"] for o in scene["objects"]} <= set(graph), graph.keys()
    assert {o["id"] for o in scene.get("overlays", [])} == {o["id"] for o in graph.values() if o["type"] == "overlay"}

    # Every solid object the scene shows has its colour and lies within the viewport (ground planes
    # may not; touched-only objects such as the positioning task's tube rims are not drawn).
    hidden = {o["id"] for o in scene["objects"] if not o["visible"]}
    hidden |= {oid for oid, shown in live_server.get("/api/state")["visible"].items() if not shown}
    solids = [o for o in graph.values() if o["type"] in ("sphere", "box", "cone", "hemisphere") and o["id"] not in hidden]
    for obj in solids:
        assert obj["visible"], obj
        hits = shows_colour(px, client, obj)
        assert hits >= 3, f"{obj['id']} ({obj['color']}) shows its colour at only {hits}/5 points"
        for p in probe_points(obj):
            x, y = client.screen(p)
            assert 0 <= x < w and 0 <= y < h, f"{obj['id']} is cut off: {p} is drawn at ({x:.0f}, {y:.0f})"

    # Every label of every visible overlay is drawn where the scene graph says.
    for overlay in (o for o in graph.values() if o["type"] == "overlay" and o["visible"]):
        for label in overlay["labels"]:
            x, y = client.screen(scene_of(label["position"]))
            assert 0 <= x < w and 0 <= y < h, label
            assert label_drawn(px, x, y), f"label {label['text']!r} of {overlay['id']} not drawn at ({x:.0f}, {y:.0f})"

    if scenario == "contact-angle-v1":
        # Default (training) state: the scale is shown, labelled -90..90 every 30, -90 on the left.
        scale = graph["angle_scale"]
        assert scale["visible"], scale
        texts = [label["text"] for label in scale["labels"]]
        assert texts == ["-90°", "-60°", "-30°", "0°", "30°", "60°", "90°"]
        xs = {label["text"]: client.screen(scene_of(label["position"])) for label in scale["labels"]}
        dome = graph["hemisphere"]
        cx, cy = client.screen(scene_of(dome["position"]))
        r_px = client.screen(scene_of(dome["position"]) + [0, dome["shape"]["radius"], 0])[0] - cx
        assert xs["-90°"][0] < cx - r_px < cx + r_px < xs["90°"][0], xs
        assert xs["0°"][1] < cy - r_px, "the 0° label sits above the top of the dome"
        assert xs["-60°"][0] < xs["-30°"][0] < xs["0°"][0] < xs["30°"][0] < xs["60°"][0]

    if scenario == "texture-v1":
        plane = graph["plane"]
        assert plane["skin"] == SKIN
        assert client.hook("skins()") == {"pending": 0, "failed": []}
        # The skin's stripes: a patch of the plane near the viewer varies a lot, around the tint.
        x, y = client.screen([0.8, 0.4, 0.0])
        box = px[int(y) - 40 : int(y) + 40, int(x) - 40 : int(x) + 40].reshape(-1, 3)
        luminance = box @ [0.2126, 0.7152, 0.0722]
        assert luminance.std() > 12, f"the skinned plane looks flat (luminance std {luminance.std():.1f})"
        assert np.abs(chroma(box.mean(axis=0)) - chroma(hex_rgb(plane["color"]))).max() < 0.05

    if scenario == "positioning-v1":
        # The tubes are meshes, drawn; the objects stand on the table, the arrow waits for a pick.
        for tube in ("cube_a_hole", "sphere_hole", "cube_b_hole"):
            assert graph[tube]["type"] == "mesh" and graph[tube]["visible"], graph[tube]
        assert not graph["arrow_head"]["visible"] and not graph["cube_a_rim"]["visible"]
        assert {"cube_a", "sphere", "cube_b"} <= {o["id"] for o in solids}
        # the experimenter widens the holes: the tubes are drawn 1.5 times as wide, not taller
        live_server.post("/api/command", {"key": "hole_scale", "value": 1.5})
        page.wait_for_function("() => window.__viestac.sceneGraph().find(o => o.id === 'cube_a_hole').scale[0] === 1.5",
                               timeout=5000)
        tube = next(o for o in client.graph().values() if o["id"] == "sphere_hole")
        assert tube["scale"] == [1.5, 1.0, 1.5], "three.js axes: scene y → X, z → Y, x → Z"
        live_server.post("/api/command", {"key": "hole_scale", "value": 1.0})
        page.wait_for_function("() => window.__viestac.sceneGraph().find(o => o.id === 'cube_a_hole').scale[0] === 1",
                               timeout=5000)

    if scenario == "peg-in-hole-v1":
        # the same table seen in perspective, which the participant may orbit
        assert scene["camera"]["projection"] == "perspective" and client.hook("orbit()")["enabled"]
        assert {"cube_a", "sphere", "cube_b"} <= {o["id"] for o in solids}
        assert all(graph[t]["type"] == "mesh" for t in ("cube_a_hole", "sphere_hole", "cube_b_hole"))

    if scenario == "hot-wire-v1":
        # the green wire is drawn along the path: sample it at points along its length
        from scenarios.registry import create

        path = create("hot-wire-v1", **params).path
        green = chroma(hex_rgb(graph["wire"]["color"]))
        shown = 0
        for k in range(1, 20):
            x, y = client.screen(path.point_at(path.length * k / 20))
            assert 0 <= x < w and 0 <= y < h, "the whole path is in view"
            if np.abs(chroma(patch(px, x, y, 1).mean(axis=0)) - green).max() < 0.08:
                shown += 1
        assert shown >= 15, f"the wire shows green at only {shown}/19 points along the path"
        assert graph["target"]["visible"] and not graph["pacer"]["visible"], "the pacer waits for the start"

    assert client.hook("stats.lastError") is None, client.hook("stats.lastError")
    assert not client.page_errors, client.page_errors
    assert not client.console_errors, client.console_errors


# -- orbit and zoom of perspective views ----------------------------------------------------------


def right_drag(page, dx: float, dy: float) -> None:
    """Drag with the right button from the middle of the view."""
    x, y = VIEWPORT["width"] / 2, VIEWPORT["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down(button="right")
    page.mouse.move(x + dx, y + dy, steps=8)
    page.mouse.up(button="right")


def shift_wheel(page, delta_y: float) -> None:
    page.keyboard.down("Shift")
    page.mouse.wheel(0, delta_y)
    page.keyboard.up("Shift")


def context_menu_suppressed(page) -> bool:
    return page.evaluate("() => !document.getElementById('view')"
                         ".dispatchEvent(new MouseEvent('contextmenu', {bubbles: true, cancelable: true}))")


def test_perspective_view_orbits_and_zooms(open_client, live_server, contact_angle_after):
    client = open_client()
    page = client.page
    client.wait_rebuilt(switch_scenario(live_server, "texture-v1", {"skin": SKIN}))
    camera = live_server.get("/api/scene")["scene"]["camera"]
    assert camera["projection"] == "perspective"
    home = client.hook("orbit()")
    assert home["enabled"], home
    assert home["position"] == pytest.approx(camera["position"], abs=1e-6)
    assert home["target"] == pytest.approx(camera["target"], abs=1e-6)
    page.evaluate("""() => { const c = window.__viestac.connection, send = c.sendInput.bind(c);
        window.__sentKeys = []; c.sendInput = (k, a, v) => { window.__sentKeys.push(k); return send(k, a, v); }; }""")

    # right-drag orbits around the target, at the same distance (to the side and from higher up),
    # and the HIP holds still meanwhile (orbiting must not drag a grasped object along)
    page.mouse.move(VIEWPORT["width"] / 2, VIEWPORT["height"] / 2)
    before = settled_position(client, live_server)
    right_drag(page, 150, 40)
    orbited = wait_for(lambda: (o := client.hook("orbit()"))["position"] != home["position"] and o,
                       what="the right-drag to orbit the camera")
    assert np.linalg.norm(np.subtract(orbited["position"], home["position"])) > 0.5, (home, orbited)
    assert orbited["target"] == pytest.approx(home["target"], abs=1e-9)
    assert orbited["distance"] == pytest.approx(home["distance"], rel=1e-6)
    assert context_menu_suppressed(page)
    client.frames_drawn(3)  # from the new viewpoint
    assert server_view(live_server, client.client_id)["last_tracker"]["pos"] == pytest.approx(before, abs=1e-9)
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / "orbit-texture.png"))

    # the HIP plane turned with the view: the middle of the view still reaches the target
    page.mouse.move(VIEWPORT["width"] / 2, VIEWPORT["height"] / 2)
    assert settled_position(client, live_server) == pytest.approx(camera["target"], abs=1e-6)

    # Shift+wheel zooms and leaves the HIP depth alone
    shift_wheel(page, -100)
    zoomed = wait_for(lambda: (o := client.hook("orbit()"))["distance"] < orbited["distance"] - 1e-6 and o,
                      what="Shift+wheel to zoom in")
    assert zoomed["target"] == pytest.approx(home["target"], abs=1e-9)
    assert client.hook("depth()") == 0

    # the plain wheel still moves the HIP depth, not the camera
    page.mouse.wheel(0, 100)
    wait_for(lambda: client.hook("depth()") != 0, what="the wheel to change the depth")
    assert client.hook("orbit()") == zoomed

    # Home brings the scene's camera back, and stays in the page
    page.keyboard.press("Home")
    wait_for(lambda: client.hook("orbit()")["position"] == pytest.approx(home["position"], abs=1e-9),
             what="Home to restore the camera")
    assert client.hook("orbit()")["distance"] == pytest.approx(home["distance"], rel=1e-9)
    assert "Home" not in page.evaluate("window.__sentKeys")
    assert client.hook("stats.lastError") is None, client.hook("stats.lastError")
    assert not client.page_errors, client.page_errors
    assert not client.console_errors, client.console_errors


def test_orthographic_view_stays_fixed(open_client, live_server, contact_angle_after):
    client = open_client()
    page = client.page
    client.wait_rebuilt(switch_scenario(live_server, "texture-v1", {"skin": SKIN}))
    home = client.hook("orbit()")
    right_drag(page, 150, 0)  # orbit the perspective scene first: the next scene must not inherit it
    wait_for(lambda: client.hook("orbit()")["position"] != home["position"], what="the orbit")
    client.wait_rebuilt(switch_scenario(live_server, "positioning-v1"))
    camera = live_server.get("/api/scene")["scene"]["camera"]
    assert camera["projection"] == "orthographic"
    fixed = client.hook("orbit()")
    assert not fixed["enabled"], fixed
    assert fixed["position"] == pytest.approx(camera["position"], abs=1e-6)

    right_drag(page, 200, -60)
    shift_wheel(page, -100)  # on a fixed view a modifier wheel is the HIP depth, as the plain one
    wait_for(lambda: client.hook("depth()") != 0, what="Shift+wheel to change the depth")
    page.keyboard.press("Home")
    page.wait_for_timeout(200)
    assert client.hook("orbit()") == fixed
    assert context_menu_suppressed(page)
    assert not client.page_errors, client.page_errors


@pytest.mark.parametrize("frame_every_ms", [0, 400], ids=["frames-as-drawn", "a-frame-every-400-ms"])
def test_scenario_switches_rebuild_without_leaks(open_client, live_server, contact_angle_after, frame_every_ms):
    client = open_client(frame_every_ms=frame_every_ms)
    client.wait_rebuilt(switch_scenario(live_server, "contact-angle"))
    ids = set(client.graph())
    memory = client.settled_memory()
    assert memory["geometries"] > 0 and memory["textures"] > 0, memory

    for name, params in [("texture", {"skin": SKIN}), ("shape", {}), ("contact-angle", {})] * 2:
        client.wait_rebuilt(switch_scenario(live_server, name, params))
        graph = client.graph()
        scene = live_server.get("/api/scene")["scene"]
        drawn = {o["id"] for o in graph.values() if o["type"] not in ("hip", "proxy")}
        assert drawn == {o["id"] for o in scene["objects"] + scene.get("overlays", [])}, "left-over elements"

    assert set(client.graph()) == ids
    assert client.settled_memory() == memory, "GPU geometries/textures leaked across rebuilds"
    assert not client.page_errors, client.page_errors


def test_operator_panel_sends_commands(open_client, live_server, contact_angle_after):
    client = open_client("?role=operator")
    page = client.page
    client.wait_rebuilt(switch_scenario(live_server, "contact-angle"))
    wait_for(lambda: client.hook("panelKeys()") == ["tap_angle", "release", "scale"], what="the operator panel")
    panel = page.locator("#operator")
    assert panel.is_visible()

    def state():
        return live_server.get("/api/state")

    # A value out of range is refused in the page: nothing is sent.
    page.fill("#operator input[data-key=tap_angle]", "120")
    page.click("#operator button[data-key=tap_angle]")
    assert "must be in [-90, 90]" in panel.locator(".panel-status").inner_text()
    page.wait_for_timeout(200)
    assert "tap_deg" not in state()["values"]

    # tap_angle -30: the server holds the HIP on the arc at -30° (left of the top).
    page.fill("#operator input[data-key=tap_angle]", "-30")
    page.click("#operator button[data-key=tap_angle]")
    wait_for(lambda: state()["values"].get("tap_deg") == -30, what="the tap at -30°")
    hip = state()["hip"]
    assert hip[1] < -0.2 and hip[2] > 0.4, hip
    wait_for(lambda: "tap" in page.inner_text("#events"), what="the tap event in the events line")

    # scale off: the server's visibility override reaches the scene graph.
    page.uncheck("#operator input[data-key=scale]")
    page.click("#operator button[data-key=scale]")
    wait_for(lambda: state()["visible"].get("angle_scale") is False, what="the scale override")
    wait_for(lambda: client.graph()["angle_scale"]["visible"] is False, what="the page to hide the scale")
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / "operator_panel.png"))

    page.check("#operator input[data-key=scale]")
    page.click("#operator button[data-key=scale]")
    page.click("#operator button[data-key=release]")
    wait_for(lambda: client.graph()["angle_scale"]["visible"] is True, what="the page to show the scale again")
    wait_for(lambda: "tap_deg" not in state()["values"], what="the release")
    assert client.hook("stats.lastError") is None, client.hook("stats.lastError")
    assert not client.page_errors, client.page_errors

    participant = open_client()
    assert participant.hook("panelKeys()") is None
    assert not participant.page.locator("#operator").is_visible()


# -- mesh shapes --------------------------------------------------------------------------------

TUBE_COLOR = "#2f6fdf"
GROUND_COLOR = "#8c8c8c"


def square_tube(outer: float, inner: float, height: float) -> tuple[list, list]:
    """A square tube standing on z = 0 around the z axis: its outer and inner walls and its top and
    bottom rims, each quad as two triangles counter-clockwise seen from outside the material."""
    vertices = []
    for half in (outer / 2, inner / 2):
        for z in (0.0, height):
            # corners counter-clockwise seen from +z
            vertices += [[half, -half, z], [half, half, z], [-half, half, z], [-half, -half, z]]

    def v(ring: int, top: int, k: int) -> int:  # ring 0 outer, 1 inner
        return ring * 8 + top * 4 + k % 4

    faces = []
    for k in range(4):
        for a, b, c, d in [(v(0, 0, k), v(0, 0, k + 1), v(0, 1, k + 1), v(0, 1, k)),  # outer wall
                           (v(1, 0, k), v(1, 1, k), v(1, 1, k + 1), v(1, 0, k + 1)),  # inner wall, faces the hole
                           (v(0, 1, k), v(0, 1, k + 1), v(1, 1, k + 1), v(1, 1, k)),  # top rim
                           (v(0, 0, k), v(1, 0, k), v(1, 0, k + 1), v(0, 0, k + 1))]:  # bottom rim
            faces += [[a, b, c], [a, c, d]]
    return vertices, faces


@pytest.fixture
def mesh_server(tmp_path):
    """A server of its own exploring a scene file: a ground plane and a 0.4 x 0.4 / 0.3 x 0.3 square
    tube 0.5 high, seen from above and in front so that the ground shows through the hole."""
    vertices, faces = square_tube(0.4, 0.3, 0.5)
    scene = {
        "name": "mesh-tube",
        "camera": {"projection": "perspective", "position": [0.5, 0.2, 2.2], "target": [0, 0, 0.2],
                   "up": [0, 0, 1], "fov_deg": 40},
        "objects": [
            {"id": "ground", "shape": {"type": "plane", "size": [2, 2]}, "material": {"color": GROUND_COLOR}},
            {"id": "tube", "shape": {"type": "mesh", "vertices": vertices, "faces": faces},
             "material": {"color": TUBE_COLOR}, "haptic": False},
        ],
    }
    path = tmp_path / "mesh_scene.json"
    path.write_text(json.dumps(scene))
    proc, base = start_server("contact-angle", extra=["--scene", str(path)])
    try:
        yield LiveServer(base, base.replace("http://", "ws://") + "/ws")
    finally:
        stop_server(proc)


def test_mesh_object_renders_and_is_freed(open_client, mesh_server):
    client = open_client(server=mesh_server)
    page = client.page
    tube = client.graph()["tube"]
    assert tube["type"] == "mesh" and tube["visible"], tube

    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    png = page.screenshot(path=str(ARTIFACTS / "mesh.png"))
    px = screenshot_pixels(page, png)[:, :, :3].astype(float)

    def colour_at(scene_pos, color: str) -> bool:
        mean = patch(px, *client.screen(scene_pos)).mean(axis=0)
        return bool(np.abs(chroma(mean) - chroma(hex_rgb(color))).max() < 0.06)

    tube_px = (np.abs(px / np.maximum(px.sum(axis=2, keepdims=True), 1) - chroma(hex_rgb(TUBE_COLOR))).max(axis=2)
               < 0.06).sum()
    assert tube_px > 5000, f"the tube's colour {TUBE_COLOR} covers only {tube_px} pixels"
    # The top rim all round and the outer wall facing the camera are drawn (outward winding:
    # culled faces would show the inside), and the ground shows through the hole.
    rim = [(0.175, 0, 0.5), (-0.175, 0, 0.5), (0, 0.175, 0.5), (0, -0.175, 0.5)]
    for p in rim + [(0.2, 0, 0.25)]:
        assert colour_at(p, TUBE_COLOR), f"no tube colour at {p}"
    assert colour_at((0, 0, 0), GROUND_COLOR), "the ground does not show through the tube's hole"
    assert client.hook("stats.lastError") is None, client.hook("stats.lastError")
    assert not client.page_errors, client.page_errors
    assert not client.console_errors, client.console_errors

    # Another scene: the mesh's geometry is freed like any shape's (same GPU memory as a page
    # that never saw the tube).
    client.wait_rebuilt(switch_scenario(mesh_server, "contact-angle"))
    assert "tube" not in client.graph()
    fresh = open_client(server=mesh_server)
    fresh.wait_rebuilt(fresh.hook("sceneHash"))
    assert client.hook("memory()") == fresh.hook("memory()"), "the mesh geometry leaked"
