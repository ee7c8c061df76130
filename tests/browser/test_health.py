"""The server's health in the browser, against a server of its own that is made to fail: the loop is
stopped (SIGSTOP) and continued, then the FerroVibe emulator of the simulated rig is killed. The
console's banner and the participant's HUD line appear while degraded and go when ok again.
Screenshots: tests/artifacts/browser/health-*.png.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import threading
import time

import pytest

from tests.browser.conftest import ARTIFACTS, new_context, require_web_deps
from tests.browser.test_console import CONSOLE_VIEWPORT, Console
from tests.browser.test_web_client import VIEWPORT, Client

pytestmark = pytest.mark.browser

BANNER = "#health-banner"
LINE = "#health"


@pytest.fixture(scope="module")
def server(own_server):
    return own_server


def visible(page, selector: str) -> bool:
    return page.evaluate("(sel) => { const el = document.querySelector(sel); return !!el && !el.hidden; }", selector)


def wait_visible(page, selector: str, shown: bool, timeout_ms: int = 10_000) -> None:
    page.wait_for_function("([sel, shown]) => { const el = document.querySelector(sel); "
                           "return !!el && el.hidden === !shown; }", arg=[selector, shown], timeout=timeout_ms)


def send_samples(sock: socket.socket, address: str, seconds: float, seq0: int = 0,
                 ttl: float | None = 40.0) -> int:
    """A UDP tracker bridge (docs/trackers.md; one socket: one source) whose samples carry a 40 ms
    ttl, for `seconds` (without a ttl, at least one sample: the source is held, never lost)."""
    host, _, port = address.rpartition(":")
    seq = seq0
    end = time.monotonic() + seconds
    while seq == seq0 or time.monotonic() < end:
        sample = {"type": "tracker", "seq": seq, "t": time.monotonic() * 1e3, "pos": [0.0, 0.1, 1.2]}
        if ttl is not None:
            sample["ttl"] = ttl
        sock.sendto(json.dumps(sample).encode(), (host, int(port)))
        seq += 1
        time.sleep(0.01)
    return seq


def test_a_lost_tracker_shows_in_the_console_banner_and_the_participant_line(browser, server):
    """Before the test below (which kills a device of this server)."""
    require_web_deps()
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    address = server.get("/api/health")["tracker_udp"]
    assert address, "the server has a tracker UDP port"
    console_ctx = new_context(browser, server.http_url, viewport=CONSOLE_VIEWPORT)
    participant_ctx = new_context(browser, server.http_url, viewport=VIEWPORT)
    bridge = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        console = Console(console_ctx.new_page(), server).open()
        participant = Client(participant_ctx.new_page(), server).open("?role=participant")
        console.page.wait_for_function("window.__console.health()?.status === 'ok'", timeout=10_000)
        seq = send_samples(bridge, address, 0.3)  # then silence: the ttl runs out, the HIP is released
        wait_visible(console.page, BANNER, True)
        wait_visible(participant.page, LINE, True)
        console.wait_text(BANNER, "stopped sending")
        assert "right.index.tip released" in console.page.inner_text(BANNER)
        assert participant.page.inner_text(LINE) == "Tactile feedback paused — tracking lost"
        assert console.page.evaluate("window.__console.health().reasons[0].code") == "tracker_lost"
        console.page.screenshot(path=str(ARTIFACTS / "health-console-tracker-lost.png"))
        participant.page.screenshot(path=str(ARTIFACTS / "health-participant-tracker-lost.png"))
        # the source returns, and stays longer than the console banner holds a cleared trouble
        # (console/health.js HOLD_MS, 3 s): a source gone again would show a new trouble
        sender = threading.Thread(target=send_samples, args=(bridge, address, 8.0, seq))
        sender.start()
        try:
            wait_visible(console.page, BANNER, False)
            wait_visible(participant.page, LINE, False)
        finally:
            sender.join()
        send_samples(bridge, address, 0.0, seq + 1000, ttl=None)  # it stays: held without a ttl, as the mouse is
        assert not console.page_errors and not participant.page_errors
    finally:
        bridge.close()
        console_ctx.close()
        participant_ctx.close()


def test_console_banner_and_participant_line_follow_health(browser, server):
    require_web_deps()
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    console_ctx = new_context(browser, server.http_url, viewport=CONSOLE_VIEWPORT)
    participant_ctx = new_context(browser, server.http_url, viewport=VIEWPORT)
    try:
        console = Console(console_ctx.new_page(), server).open()
        participant = Client(participant_ctx.new_page(), server).open("?role=participant")
        console.page.wait_for_function("window.__console.health()?.status === 'ok'", timeout=10_000)
        # the banner holds a cleared trouble (the start-up) for its HOLD_MS (console/health.js), then goes
        wait_visible(console.page, BANNER, False)
        assert not visible(participant.page, LINE)

        # a stalled loop: both show it, both clear when it ticks again
        pid = server.get("/api/health")["loop"]["pid"]
        os.kill(pid, signal.SIGSTOP)
        try:
            wait_visible(console.page, BANNER, True)
            wait_visible(participant.page, LINE, True)
            assert "server not responding" in participant.page.inner_text(LINE)
            assert "not ticked" in console.page.inner_text(BANNER)
        finally:
            os.kill(pid, signal.SIGCONT)
        wait_visible(console.page, BANNER, False)
        wait_visible(participant.page, LINE, False)

        # the device the running scenario needs is gone
        emulators = server.get("/api/devices")["simulated_rig"]["emulators"]
        os.kill(emulators["ferrovibe"]["pid"], signal.SIGKILL)
        wait_visible(console.page, BANNER, True)
        wait_visible(participant.page, LINE, True)
        console.wait_text(BANNER, "'ferrovibe' is disconnected")
        # a loaded machine may add a passing loop_stalled first: wait for the device's own line
        participant.page.wait_for_function(
            "([sel, text]) => document.querySelector(sel)?.innerText === text",
            arg=[LINE, "Tactile feedback paused — device disconnected"], timeout=10_000)
        assert "device_missing" in console.page.evaluate("window.__console.health().reasons.map(r => r.code)")
        console.page.screenshot(path=str(ARTIFACTS / "health-console-degraded.png"))
        participant.page.screenshot(path=str(ARTIFACTS / "health-participant-degraded.png"))
        assert not console.page_errors and not participant.page_errors
    finally:
        console_ctx.close()
        participant_ctx.close()
