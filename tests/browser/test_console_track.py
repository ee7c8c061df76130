"""The console's live psychophysics track (clients/web/src/console/track.js) in headless Chromium,
against a real server and a real session: `GET /api/sessions/{id}/tracks` (Contract C4, built by
the study part) is answered here by Playwright with constructed bodies, so the card's fetching on
refresh, its drawing and its hiding are checked on this branch alone. Screenshot:
tests/artifacts/browser/console-track.png.
"""

from __future__ import annotations

import json

import pytest

from tests.browser.conftest import ARTIFACTS
from tests.browser.test_console import Console, console_server, open_page  # noqa: F401 - fixtures

pytestmark = pytest.mark.browser


def body(sid: str, trials: list[dict], estimate: float | None) -> dict:
    return {"session": sid, "tasks": [{"task": "detect", "design": "2ifc", "parameter": "intensity_pct", "unit": "%",
                                       "procedure": "up-down", "finished": False,
                                       "conditions": [{"name": "f250", "finished": False, "estimate": estimate,
                                                       "trials": trials}]}]}


TRIALS = [{"seq": 2, "level": 40.0, "answer": "1", "correct": True, "reversal": False},
          {"seq": 3, "level": 40.0, "answer": "2", "correct": True, "reversal": False},
          {"seq": 4, "level": 32.0, "answer": "1", "correct": False, "reversal": True}]


def test_the_track_card_draws_the_tracks_refreshes_and_hides(open_page, console_server):  # noqa: F811
    server = console_server
    console = Console(open_page(server=server), server).open()
    page = console.page
    page.fill("#experimenter", "alice")
    page.fill("#participant", "P71")
    page.fill("#device", "ferrovibe")
    page.click("#create")
    console.wait_state("s.sessionId && s.control === 'yes'")
    sid = console.state()["sessionId"]
    answer = {"body": body(sid, TRIALS, None), "status": 200}
    asked = []

    def tracks(route):
        asked.append(route.request.url)
        route.fulfill(status=answer["status"], content_type="application/json", body=json.dumps(answer["body"]))

    page.route(f"**/api/sessions/{sid}/tracks", tracks)
    page.wait_for_selector("#track-card:not([hidden]) svg.c-track", timeout=10_000)
    svg = page.locator("#track svg.c-track")
    assert svg.count() == 1 and svg.get_attribute("role") == "img"
    title_id, desc_id = svg.get_attribute("aria-labelledby").split()
    assert page.locator(f"#{desc_id}").text_content() == ("detect, f250: 3 trials, last level 32 %, 2 correct, "
                                                          "1 wrong, 1 reversals, current estimate —")
    assert "intensity_pct per trial" in page.locator(f"#{title_id}").text_content()
    assert page.locator("#track .c-track-correct").count() == 2
    assert page.locator("#track .c-track-wrong").count() == 1
    assert page.locator("#track .c-track-reversal").count() == 1
    assert page.locator("#track .c-track-estimate").count() == 0

    # the next refresh brings a new trial and an estimate: redrawn without a reload
    answer["body"] = body(sid, [*TRIALS, {"seq": 5, "level": 36.0, "answer": "2", "correct": True,
                                          "reversal": False}], 34.0)
    page.wait_for_function("document.querySelectorAll('#track .c-track-point').length === 4", timeout=10_000)
    assert page.locator("#track .c-track-estimate").count() == 1
    assert "estimate 34 %" in page.locator("#track figcaption").text_content()
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page.locator("#track-card").screenshot(path=str(ARTIFACTS / "console-track.png"))

    # a session without psychophysics tasks: the endpoint says 404 and the card hides
    answer.update(status=404, body={"detail": "no psychophysics task"})
    page.wait_for_selector("#track-card[hidden]", state="attached", timeout=10_000)
    assert all(url.endswith(f"/api/sessions/{sid}/tracks") for url in asked) and len(asked) >= 3
    assert not console.page_errors, console.page_errors
