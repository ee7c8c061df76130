"""Pick and place with a mouse (issue 34.6): a mouse drives one point, so the thumb never moves and
no grasp can happen. The page must say so (docs/scenarios.md "pick-place-v1", one-point rig)
instead of asking to "Grasp the block between thumb and index"."""

from __future__ import annotations

import pytest

from tests.browser.conftest import ARTIFACTS, new_context, require_web_deps
from tests.browser.test_a11y import LOADED_MS
from tests.browser.test_web_client import Client, wait_tracker
from tests.live_server import LiveServer, start_server, stop_server

pytestmark = pytest.mark.browser


@pytest.fixture(scope="module")
def pick_place():
    proc, base = start_server("pick-place", extra=["--force"])
    try:
        yield LiveServer(base, base.replace("http://", "ws://") + "/ws")
    finally:
        stop_server(proc)


def test_a_mouse_is_told_that_pick_and_place_needs_two_tracked_fingers(browser, pick_place):
    require_web_deps()
    ctx = new_context(browser, pick_place.http_url, viewport={"width": 1280, "height": 800})
    try:
        ctx.set_default_timeout(LOADED_MS)
        page = ctx.new_page()
        client = Client(page, pick_place).open()
        x, y = client.screen((0.0, 0.9, 0.3))  # the block's top
        page.mouse.move(x, y, steps=5)
        wait_tracker(pick_place, client.client_id, timeout=10)
        page.wait_for_function(
            "(document.getElementById('hud')?.innerText ?? '').includes('not tracked: right.thumb.tip')",
            timeout=15_000)
        hud = page.inner_text("#hud")
        assert "Pick and place needs two tracked fingers" in hud and "mouse" in hud, hud
        assert "Grasp the block" not in hud
        ARTIFACTS.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(ARTIFACTS / "pick-place-mouse.png"))
        assert not client.page_errors
    finally:
        ctx.close()
