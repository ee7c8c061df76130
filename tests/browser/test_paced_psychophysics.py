"""Issue 36's acceptance: a participant-paced 2IFC staircase runs from the participant's page
alone — keys in headless Chromium, ray and pinch in the emulated headset — with the procedure's
feedback. The tests are test_paced.py's, run on a psychophysics study (the stimulus scenario, a
1-up/2-down staircase whose trials carry metrics.psy.correct, so feedback must show)."""

from __future__ import annotations

import pytest

from tests.browser.test_console import CONSOLE_VIEWPORT
from tests.browser.test_paced import (PacedStudy, console_session, contexts, join, paced_server,  # noqa: F401
                                      wait_asked, wait_status)

pytestmark = pytest.mark.browser

STUDY = """
id = "paced-2ifc"
title = "A participant-paced 2IFC staircase"
seed = 11
participants = 4

[[tasks]]
id = "detect"
scenario = "stimulus"
device = "fingertac"
params = { cue = "vibration", duration_ms = 100, isi_ms = 100, lead_ms = 100 }
instructions = "Two intervals per trial; one holds a vibration. Press 1 or 2."

[tasks.psychophysics]
design = "2ifc"
parameter = "intensity_pct"
max_trials = 5

[tasks.psychophysics.procedure]
kind = "up-down"
scale = "db"
start = 50
steps = [6]
up = 1
down = 2
min = 1
max = 100
max_trials = 5

[tasks.pacing]
by = "participant"
iti_ms = 400
feedback = true
feedback_ms = 300
break_every = 2
"""


@pytest.fixture(scope="module")
def paced_study() -> PacedStudy:
    return PacedStudy(STUDY, "paced-2ifc", "response", ("1", "2"), scenario="stimulus", feedback=True)


def test_the_console_shows_the_running_track_of_a_paced_staircase(contexts, paced_server, paced_study):  # noqa: F811
    """The real tracks endpoint behind the console's track card: each answer the participant's keys
    give appears as a point at the level the procedure presented."""
    server, study = paced_server, paced_study
    console, sid = console_session(contexts(server, viewport=CONSOLE_VIEWPORT), server, study, "P13")
    participant = contexts(server, token=None)
    join(participant, server, sid)
    console.click("#start")
    for seq, key in enumerate("21"):  # two trials, then the break holds the third
        wait_asked(participant, seq)
        participant.keyboard.press(key)
        wait_status(server, sid, seq, "answered")
    page = console.page
    page.wait_for_function("document.querySelectorAll('#track .c-track-point').length === 2", timeout=10_000)
    track = server.get(f"/api/sessions/{sid}/tracks")["tasks"][0]["conditions"][0]["trials"]
    assert [t["seq"] for t in track] == [0, 1]
    assert [t["answer"] for t in track] == ["2", "1"]
    levels = [t["params"]["level_1"] or t["params"]["level_2"]
              for t in server.get(f"/api/sessions/{sid}")["trials"][:2]]
    assert [t["level"] for t in track] == levels, "the track shows the levels presented"
    described = page.locator("#track svg.c-track").get_attribute("aria-labelledby").split()[1]
    assert page.locator(f"#{described}").text_content().startswith("detect, main: 2 trials")
    assert not console.page_errors


# test_paced.py's tests run after the one above (collection follows this module's order): its
# headset test leaves a trial running, which keeps other sessions' join links out (409)
from tests.browser.test_paced import (test_a_paced_task_runs_from_the_participants_keys,  # noqa: E402
                                      test_the_emulated_headset_answers_a_paced_task_by_pinch)

__all__ = ["test_the_console_shows_the_running_track_of_a_paced_staircase",
           "test_a_paced_task_runs_from_the_participants_keys",
           "test_the_emulated_headset_answers_a_paced_task_by_pinch"]
