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
from tests.browser.test_web_client import (  # noqa: F401  (fixtures)
    VIEWPORT, chroma, contact_angle_after, hex_rgb, open_client, screenshot_pixels, wait_for)

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
    assert g["hand"]["visible"] and len(g["hand"]["joints"]) == 26 and len(g["hand"]["bones"]) == 24
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
    assert not g[f"hip:{THUMB}"]["contact"] and not g[f"proxy:{THUMB}"]["visible"] and not g["hand"]["visible"]
    page.screenshot(path=str(ARTIFACTS / "hands_tracking_lost.png"))

    # the source is back: the banner goes
    page.evaluate(INJECT, {"tools": tools[:1], "points": {}, "tracking": {"lost": []}})
    page.locator("#tracking").wait_for(state="hidden", timeout=5000)
    g = graph(client)
    assert f"hip:{THUMB}" not in g, "a tool the frame no longer lists is not drawn"
    assert not client.page_errors, client.page_errors
