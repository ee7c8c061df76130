"""The scripted lab day (issue 34's acceptance), beside a CPU hog: log in with a login link, take
the rig's control lease, create a session, open its join link in a second browser context, run
five trials the participant answers on its page, reloading each page mid-trial, release and
re-request the lease mid-session, kill a device emulator and start it again, then export and
analyze. It asserts: no page is left unadmitted (each reload is admitted on its own), no silent
lockout (after the lease came back the participant still drives and answers), the device fault
shows in the console within 1 s, the export and the analysis complete.

The console's devices panel's selectors are kept in the block below.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from devices.rig import emulator_command
from tests.browser.conftest import ARTIFACTS, new_context, require_web_deps
from tests.browser.test_a11y import (LOADED_MS, NOT_ADMITTED, READY_JS, STUDY, STUDY_ID, Console, join, join_link,
                                     open_session, question_shown, start_trial, trial_of)
from tests.browser.test_access import login_code
from tests.browser.test_web_client import wait_for, wait_tracker
from tests.live_server import LiveServer, get_json, start_server, stop_server

pytestmark = [pytest.mark.browser, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]

# -- the console's devices panel (clients/web/src/console/devices.js) ---------------------------------
# One element per device carrying its state: data-status "ok" (connected) or "bad".
DEVICE_ELEMENT = '#devices-panel [data-device="{name}"]'
DEVICE_STATE_ATTR = "data-status"
DEVICE_DOWN = re.compile(r"^bad$")
DEVICE_UP = re.compile(r"^ok$")
# ------------------------------------------------------------------------------------------------------

TRIALS = 5
RELEASE_BEFORE = 3       # the lease is released and re-requested before this trial
KILL_DURING = 4          # the emulator is killed and restarted during this trial
FAULT_SHOWN_S = 1.0      # the acceptance: the device fault in the console within 1 s
HOGS = 1                 # busy processes beside the test (the machine is shared: one is enough)


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    """A server nobody holds the lease of, with the lab study; `.data_dir` is its data directory."""
    work = tmp_path_factory.mktemp("lab-day")
    studies, data = work / "studies", work / "data"
    studies.mkdir()
    (studies / f"{STUDY_ID}.toml").write_text(STUDY, encoding="utf-8")
    proc, base = start_server("contact-angle", take_lease=False,
                              extra=["--studies", str(studies), "--data-dir", str(data), "--force"])
    try:
        server = LiveServer(base, base.replace("http://", "ws://") + "/ws")
        server.data_dir = data
        yield server
    finally:
        stop_server(proc)


@pytest.fixture
def cpu_hog():
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(HOGS)]
    yield
    for hog in hogs:
        hog.kill()
        hog.wait()


T0 = time.monotonic()  # reset by the test


def step(what: str) -> None:
    """A progress line (pytest -s shows them): where the day is, and when."""
    print(f"lab day {time.monotonic() - T0:6.1f} s: {what}", file=sys.stderr, flush=True)


def admitted(page) -> bool:
    return page.evaluate(READY_JS)


def reload_admitted(page, what: str, failures: list[str]) -> None:
    """Reload `page`; it must get ready on its own, never stopping at "not admitted". When it does
    stop there, that is recorded and the page reloaded again by hand (as the lab did), so that the
    day goes on."""
    for attempt in range(3):
        page.reload()
        page.wait_for_function(f"({READY_JS}) || (document.getElementById('waiting')?.innerText ?? '')"
                               f".includes({NOT_ADMITTED!r})", timeout=LOADED_MS)
        if admitted(page):
            return
        said = page.evaluate("document.getElementById('waiting')?.innerText ?? ''")
        if attempt == 0:
            failures.append(f"{what}: after a reload the page is left unadmitted: {said!r}")
    raise AssertionError(f"{what}: not admitted after 3 reloads: {said!r}")


def answer(participant, angle: float, sure: int) -> None:
    page = participant.page
    question_shown(participant, "Which angle")
    page.fill("#answer input", str(angle))
    page.click("#answer button")
    question_shown(participant, "How sure")
    page.click(f'#answer button[data-value="{sure}"]')


def drives(rig: LiveServer, participant) -> None:
    """The participant's pointer moves reach the server as tracker samples."""
    page = participant.page
    before = participant.client_id
    for k in range(6):
        x, y = participant.screen((0.0, 0.2 + 0.02 * k, 0.9))
        page.mouse.move(x, y, steps=2)
    wait_tracker(rig, before, timeout=10)


def device_state(console: Console, name: str) -> str | None:
    return console.page.evaluate(
        "([sel, attr]) => document.querySelector(sel)?.getAttribute(attr) ?? null",
        [DEVICE_ELEMENT.format(name=name), DEVICE_STATE_ATTR])


def test_a_lab_day(browser, rig, cpu_hog):
    global T0
    T0 = time.monotonic()
    require_web_deps()
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    failures: list[str] = []  # assertions of parts other engineers build today: collected, reported at the end
    contexts = []
    emulator = None
    try:
        # log in (a login link), take the lease, create the session, a join link
        ctx = new_context(browser, rig.http_url, token=None, viewport={"width": 1440, "height": 900})
        contexts.append(ctx)
        ctx.set_default_timeout(LOADED_MS)  # the shared machine is loaded beyond the hog: navigations are slow
        console = Console(ctx.new_page(), rig).open(f"#login={login_code(rig)}")
        console.page.wait_for_function("window.__console.identity()?.role === 'admin'", timeout=LOADED_MS)
        console.page.wait_for_selector("#lease-request", timeout=LOADED_MS)
        console.click("#lease-request")
        console.page.wait_for_function("window.__console.lease().you === 'holder'", timeout=LOADED_MS)
        sid = open_session(console, "P01")
        url = join_link(console)
        pctx = new_context(browser, rig.http_url, token=None, viewport={"width": 1280, "height": 800})
        contexts.append(pctx)
        pctx.set_default_timeout(LOADED_MS)
        participant = join(pctx.new_page(), rig, url, reload_unadmitted=False)

        step(f"session {sid} open, participant joined")
        for seq in range(TRIALS):
            step(f"trial {seq}")
            if seq == RELEASE_BEFORE:  # the experimenter releases the rig and takes it back
                console.click("#lease-release")
                console.page.wait_for_function("window.__console.lease().you === 'none'", timeout=LOADED_MS)
                console.click("#lease-request")
                console.page.wait_for_function("window.__console.lease().you === 'holder'", timeout=LOADED_MS)
            start_trial(console, rig, sid, seq)
            if seq == RELEASE_BEFORE:
                # no silent lockout: the page is not sent back to waiting, and it drives
                try:
                    participant.page.wait_for_function(
                        "document.getElementById('waiting').hidden", timeout=10_000)
                    drives(rig, participant)
                except Exception as exc:  # noqa: BLE001 (reported below with the page's words)
                    failures.append(f"trial {seq}: after the lease's release and re-request the participant is "
                                    f"locked out: {participant.page.inner_text('#waiting')!r} / "
                                    f"{participant.page.inner_text('#status')!r} ({type(exc).__name__})")
            if seq == KILL_DURING:
                emulator, shown_s = kill_and_restart(rig, console, "ferrovibe")
                if shown_s is None or shown_s > FAULT_SHOWN_S:
                    failures.append(f"trial {seq}: the killed ferrovibe emulator was not shown in the console within "
                                    f"{FAULT_SHOWN_S} s (shown after {shown_s} s; looked for "
                                    f"{DEVICE_ELEMENT.format(name='ferrovibe')!r} and its {DEVICE_STATE_ATTR})")
            # mid-trial: reload both pages; each is admitted again on its own
            reload_admitted(participant.page, f"trial {seq}, participant", failures)
            reload_admitted_console(console, sid, f"trial {seq}, console", failures)
            try:
                answer(participant, [10, -30, 50, -70, 30][seq], 4 + seq % 3)
                wait_for(lambda seq=seq: len(trial_of(rig, sid, seq)["responses"]) == 2, timeout=15,
                         what=f"trial {seq}: both answers recorded")
            except Exception as exc:  # noqa: BLE001
                failures.append(f"trial {seq}: the participant could not answer ({exc}); its page says "
                                f"{participant.page.inner_text('#waiting')!r} / {participant.page.inner_text('#status')!r}")
                force_answers(console)
            console.click("#finish")
            wait_for(lambda seq=seq: trial_of(rig, sid, seq)["status"] == "answered", timeout=20,
                     what=f"trial {seq} answered (the console says {console.text('#run-msg')!r})")
        console.page.screenshot(path=str(ARTIFACTS / "lab-day-console.png"), full_page=True)
        participant.page.screenshot(path=str(ARTIFACTS / "lab-day-participant.png"))

        step("export and analyze")
        out = Path(rig.data_dir).parent / "out"
        run_cli("export", sid, "--out", str(out / "export"), "--data-dir", str(rig.data_dir))
        assert (out / "export").is_dir() and any((out / "export").rglob("*.csv"))
        run_cli("analyze", str(rig.data_dir), "--out", str(out / "report"), "--study", STUDY_ID)
        assert (out / "report" / "report.html").exists() and (out / "report" / "stats.json").exists()
        answered = [t for t in get_json(f"{rig.http_url}/api/sessions/{sid}")["trials"] if t["status"] == "answered"]
        assert len(answered) == TRIALS
        assert not console.page_errors and not participant.page_errors, (console.page_errors, participant.page_errors)
    finally:
        if emulator is not None:
            emulator.kill()
            emulator.wait()
        for c in contexts:
            c.close()
    assert not failures, "the lab day went wrong:\n" + "\n".join(failures)


def reload_admitted_console(console: Console, sid: str, what: str, failures: list[str]) -> None:
    """Reload the console mid-trial: it comes back logged in, with the session and its control, and
    its participant's view (an observer page in an iframe) is admitted on its own."""
    console.page.reload()
    console.page.wait_for_function("window.__console && window.__console.ready", timeout=LOADED_MS)
    console.wait_state(f"s.sessionId === {sid!r} && s.control === 'yes' && s.running !== null", timeout_ms=LOADED_MS)
    frame = "document.querySelector('#scene-frame')?.contentWindow"
    console.page.wait_for_function(
        f"{frame}?.__viestac?.ready === true || ({frame}?.document.getElementById('waiting')?.innerText ?? '')"
        ".includes('(no hello')", timeout=LOADED_MS)
    if not console.page.evaluate(f"{frame}?.__viestac?.ready === true"):
        said = console.page.evaluate(f"{frame}.document.getElementById('waiting').innerText")
        failures.append(f"{what}: the console's participant's view is left unadmitted: {said!r}")


def force_answers(console: Console) -> None:
    """The experimenter enters what the participant could not (so that the day goes on)."""
    page = console.page
    page.fill('fieldset[data-question="answer_deg"] input[type="number"]', "0")
    page.check('fieldset[data-question="sure"] input[value="4"]')
    page.click("#save-answers")


def kill_and_restart(rig: LiveServer, console: Console, model: str) -> tuple[subprocess.Popen, float | None]:
    """SIGKILL the rig's emulator of `model` (as server/bench/faults.py does) and time how long the
    console takes to show the device as down; then start a new emulator at the same link. The new
    one is this test's to stop."""
    info = get_json(f"{rig.http_url}/api/devices")["simulated_rig"]["emulators"][model]
    t0 = time.monotonic()
    os.kill(info["pid"], signal.SIGKILL)
    shown = None
    while time.monotonic() - t0 < 5.0:
        state = device_state(console, model)
        if state is not None and DEVICE_DOWN.search(state):
            shown = time.monotonic() - t0
            break
        time.sleep(0.02)
    proc = subprocess.Popen(emulator_command(model, Path(info["link"]), Path(info["timeline"]), append_timeline=True),
                            stdout=subprocess.DEVNULL, cwd=ROOT, start_new_session=True)
    wait_for(lambda: any(d["name"] == model and d["status"] == "connected" for d in get_json(f"{rig.http_url}/api/devices")
                         ["devices"]), timeout=20, what=f"{model} connected again")
    return proc, shown


def run_cli(*args: str) -> None:
    done = subprocess.run([sys.executable, "-m", "server.cli", *args], capture_output=True, text=True, timeout=120,
                          cwd=ROOT)
    assert done.returncode == 0, f"viestac {args[0]} failed ({done.returncode}): {done.stderr[-2000:]}"
