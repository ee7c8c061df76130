"""The browser client draws every tool, the tracked hand and says when tracking is lost
(clients/web/src/tools_view.js, hand.js, hud.js), in headless Chromium against a live server.

`test_drawn_from_state_fields` adds the protocol v1.4 fields (`tools`, `points`, `tracking`) to
the server's own state frames inside the page, so the drawing is checked on exact, known inputs;
the live tests further down send real tracker samples and let the server say it.
"""

from __future__ import annotations

import numpy as np
import pytest

from server.core.points import FINGERS, finger_joints, hand_points
from tests.browser.conftest import ARTIFACTS
from tests.browser import test_web_client as web
from tests.browser.test_web_client import chroma, hex_rgb, screenshot_pixels, switch_scenario, wait_for

open_client = web.open_client  # the web client tests' fixtures: a page on the live server, and
contact_angle_after = web.contact_angle_after  # putting the server back on contact-angle

pytestmark = pytest.mark.browser

INDEX, THUMB = "right.index.tip", "right.thumb.tip"
THUMB_COLOR = "#35c4e8"  # tools_view.js FINGER_COLORS.thumb


def synthetic_hand(wrist=(0.3, 0.85, 0.05), size=0.8) -> dict[str, list[float]]:
    """Every joint of a right hand, fingers up (+z) and spread across y, thumb toward −y."""
    wx, wy, wz = wrist
    spread = {"thumb": -0.22, "index": -0.1, "middle": 0.0, "ring": 0.1, "pinky": 0.19}
    heights = {"metacarpal": 0.08, "proximal": 0.28, "intermediate": 0.42, "distal": 0.52, "tip": 0.6}
    thumb = {"metacarpal": (0.05, 0.05), "proximal": (0.12, 0.15), "distal": (0.2, 0.24), "tip": (0.3, 0.33)}
    out = {"right.wrist": [wx, wy, wz]}
    for f in FINGERS:
        for j in finger_joints(f):
            if f == "thumb":
                dy, dz = thumb[j]
                out[f"right.{f}.{j}"] = [wx, wy - dy * size, wz + dz * size]
            else:
                out[f"right.{f}.{j}"] = [wx, wy + spread[f] * size, wz + heights[j] * size]
    out["right.palm"] = [wx, wy - 0.02 * size, wz + 0.18 * size]
    assert set(out) == set(hand_points("right"))
    return out


INJECT = """(extra) => { const c = window.__viestac.connection;
    if (!c.__inner) { c.__inner = c.onState; c.onState = (s) => c.__inner({ ...s, ...window.__extra }); }
    window.__extra = extra; }"""


def graph(client) -> dict[str, dict]:
    return {o["id"]: o for o in client.hook("sceneGraph()")}


def hand_drawn(client) -> tuple[int, int]:
    """(joints, bones) of the hand the page draws."""
    hand = client.hook("hand()")
    assert hand["visible"] == bool(hand["joints"])
    return len(hand["joints"]), len(hand["bones"])


def test_drawn_from_state_fields(open_client):
    client = open_client()
    page = client.page
    hand = synthetic_hand()
    index_tip, thumb_tip = hand.pop(INDEX), hand.pop(THUMB)
    thumb_proxy = [thumb_tip[0], thumb_tip[1], thumb_tip[2] + 0.08]
    tools = [{"name": INDEX, "hip": index_tip, "proxy": index_tip, "contact": False, "lost": False},
             {"name": THUMB, "hip": thumb_tip, "proxy": thumb_proxy, "contact": True, "lost": False}]
    page.evaluate(INJECT, {"tools": tools, "points": hand, "tracking": {"lost": []}})
    wait_for(lambda: f"hip:{THUMB}" in graph(client), what="the thumb's tool drawn")
    page.wait_for_timeout(200)
    g = graph(client)
    assert g["hip"]["tool"] == INDEX and g["hip"]["visible"] and not g["hip"]["contact"]
    thumb = g[f"hip:{THUMB}"]
    assert thumb["visible"] and thumb["contact"] and thumb["color"] == THUMB_COLOR
    assert g[f"proxy:{THUMB}"]["visible"], "the thumb's proxy is apart from its HIP"
    assert not g["proxy"]["visible"], "the index's proxy sits on its HIP"
    assert hand_drawn(client) == (26, 24)
    assert page.locator("#tracking").is_hidden()

    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    png = page.screenshot(path=str(ARTIFACTS / "hands_two_tools.png"))
    px = screenshot_pixels(page, png)[:, :, :3].astype(float)
    # above the tip's centre, clear of the bone that ends there
    x, y = client.screen([thumb_tip[0], thumb_tip[1], thumb_tip[2] + 0.6 * thumb["radius"]])
    patch = px[int(y) - 1: int(y) + 2, int(x) - 1: int(x) + 2].reshape(-1, 3).mean(axis=0)
    assert np.abs(chroma(patch) - chroma(hex_rgb(THUMB_COLOR))).max() < 0.12, f"thumb colour at its tip: {patch}"
    # a bone between two joints shows the hand's colour (not the background) halfway along it
    a, b = hand["right.middle.proximal"], hand["right.middle.intermediate"]
    mx, my = client.screen([(p + q) / 2 for p, q in zip(a, b)])
    background = px[5, 5]
    assert np.abs(px[int(my), int(mx)] - background).max() > 40, "no bone drawn between two joints"

    # a lost source: the banner says so, the lost tool fades and shows no contact
    tools[1] = {**tools[1], "lost": True}
    page.evaluate(INJECT, {"tools": tools, "points": {}, "tracking": {"lost": ["leap"]}})
    page.locator("#tracking").wait_for(state="visible", timeout=5000)
    assert "Tracking lost" in page.locator("#tracking").inner_text()
    wait_for(lambda: graph(client)[f"hip:{THUMB}"]["lost"], what="the thumb drawn as lost")
    g = graph(client)
    assert not g[f"hip:{THUMB}"]["contact"] and not g[f"proxy:{THUMB}"]["visible"] and hand_drawn(client) == (0, 0)
    page.screenshot(path=str(ARTIFACTS / "hands_tracking_lost.png"))

    # the source is back: the banner goes
    page.evaluate(INJECT, {"tools": tools[:1], "points": {}, "tracking": {"lost": []}})
    page.locator("#tracking").wait_for(state="hidden", timeout=5000)
    g = graph(client)
    assert f"hip:{THUMB}" not in g, "a tool the frame no longer lists is not drawn"
    assert not client.page_errors, client.page_errors


# -- live: the page sends a tracked hand (v1.4 tracker: point, points, ttl), the server says it ------

# A page's timers stall while SwiftShader renders a frame (~100 ms on this machine under load): a
# streaming tracker's usual 20-60 ms ttl would call the page lost between its own samples.
TTL_MS = 400
STREAM = """([frames, periodMs, ttl]) => { const v = window.__viestac; let k = 0;
    clearInterval(window.__stream);
    window.__stream = setInterval(() => {
      const f = frames[Math.min(k++, frames.length - 1)];
      v.connection.sendTracker(f.index, null, { point: 'right.index.tip', points: f.points, ttl });
    }, periodMs); }"""


JOINT_AT = {"metacarpal": 0.15, "proximal": 0.45, "intermediate": 0.65, "distal": 0.82, "tip": 1.0}
THUMB_AT = {"metacarpal": 0.2, "proximal": 0.45, "distal": 0.75, "tip": 1.0}


def pinching_hand(index_tip, thumb_tip) -> dict[str, list[float]]:
    """A right hand reaching down from above and in front to pinch with `index_tip` and
    `thumb_tip`: each finger a chain from the wrist to its tip, knuckles bulging up; the other
    fingers curled beside the index."""
    ix, iy, iz = index_tip
    wrist = (ix + 0.15, (iy + thumb_tip[1]) / 2 + 0.1, iz + 0.55)
    tips = {"thumb": thumb_tip, "index": index_tip}
    for k, f in enumerate(("middle", "ring", "pinky"), start=1):
        tips[f] = (ix + 0.02 * k, iy + 0.07 * k, iz + 0.1 * k)
    out = {"right.wrist": list(wrist)}
    for f, tip in tips.items():
        for j, at in (THUMB_AT if f == "thumb" else JOINT_AT).items():
            bulge = 0.12 * 4 * at * (1 - at)
            out[f"right.{f}.{j}"] = [w + at * (t - w) for w, t in zip(wrist, tip)]
            out[f"right.{f}.{j}"][2] += bulge
    out["right.palm"] = [w + 0.3 * (t - w) for w, t in zip(wrist, index_tip)]
    assert set(out) == set(hand_points("right"))
    return out


def hand_frames(centre, gaps) -> list[dict]:
    """A right hand pinching a block at `centre` across y: index on the +y face, thumb on the −y
    face, each `gap` from touching (negative: pressed in)."""
    from scenarios.pick_place import BLOCK_SIDE
    touch = BLOCK_SIDE / 2 + 0.06
    frames = []
    for gap in gaps:
        x, y, z = centre
        index, thumb = [x, y + touch + gap, z], [x, y - touch - gap, z]
        hand = pinching_hand(index, thumb)
        hand.pop(INDEX)
        frames.append({"index": index, "points": hand})
    return frames


def test_live_two_fingers_grasp_hand_and_tracking_loss(open_client, live_server, contact_angle_after):
    client = open_client()
    page = client.page
    client.wait_rebuilt(switch_scenario(live_server, "pick-place"))
    from scenarios.pick_place import BLOCK_SIDE, BLOCK_START
    centre = (*BLOCK_START, BLOCK_SIDE / 2)
    gaps = [0.1 - k * 0.13 / 40 for k in range(41)]  # from 0.1 outside to 0.03 pressed in, over 0.4 s
    page.evaluate(STREAM, [hand_frames(centre, gaps), 10, TTL_MS])
    wait_for(lambda: live_server.get("/api/state")["values"].get("phase") == "held", timeout=10,
             what="the server to see the grasp")
    wait_for(lambda: graph(client).get(f"hip:{THUMB}", {}).get("contact"), what="the thumb drawn in contact")
    g = graph(client)
    assert g["hip"]["tool"] == INDEX and g["hip"]["contact"]
    assert hand_drawn(client) == (26, 24), "the hand's joints with both tools' tips, and every bone"
    assert page.locator("#tracking").is_hidden()
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / "pick_place_grasp.png"))

    # the source stops: within its ttl the server calls it lost; the page says so
    page.evaluate("clearInterval(window.__stream)")
    page.locator("#tracking").wait_for(state="visible", timeout=5000)
    g = graph(client)
    assert g["hip"]["lost"] and g[f"hip:{THUMB}"]["lost"] and not g["hip"]["contact"]
    assert live_server.get("/api/state")["values"].get("phase") == "idle", "the block was dropped"
    page.screenshot(path=str(ARTIFACTS / "pick_place_tracking_lost.png"))

    # it sends again: tracking is back
    page.evaluate(STREAM, [hand_frames(centre, [0.1]), 10, TTL_MS])
    page.locator("#tracking").wait_for(state="hidden", timeout=5000)
    assert not graph(client)["hip"]["lost"]
    page.evaluate("clearInterval(window.__stream)")
    assert not client.page_errors, client.page_errors
    assert client.hook("stats.lastError") is None, client.hook("stats.lastError")
