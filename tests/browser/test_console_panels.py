"""The console's devices panel, scenario card and button words, and the API documentation pages,
in headless Chromium against a server of this module's own (its emulators are killed):

- the devices panel lists each device with its state, link counters and what the running
  scenario needs; a killed emulator shows in the panel and the banner within 1 s, and clears when
  it is back;
- a trial started while the device its scenario needs is off is flagged in the queue;
- the scenario card switches scenarios with declared parameters, refuses out-of-range values, and
  says a refusal without the lease in the button's words;
- the header names "Take control of this session" and "Request control" apart;
- /docs (Swagger UI) and /redoc render with every request to anything but the server blocked.
Screenshots: tests/artifacts/browser/panels-*.png.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import time
import urllib.error
import urllib.request
from pathlib import Path
from urllib.parse import urlparse

import pytest

from devices.rig import emulator_command
from scenarios.registry import resolve
from tests.live_server import auth_headers
from tests.browser.conftest import ARTIFACTS, new_context, require_web_deps
from tests.browser.test_console import CONSOLE_VIEWPORT, Console
from tests.browser.test_web_client import wait_for

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def server(own_server):
    return own_server


@pytest.fixture
def console(browser, server):
    require_web_deps()
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    ctx = new_context(browser, server.http_url, viewport=CONSOLE_VIEWPORT)
    try:
        page = ctx.new_page()
        c = Console(page, server).open()
        page.wait_for_function("window.__console.devices()?.rows?.length === 2", timeout=15_000)
        yield c
        assert not c.page_errors, c.page_errors
    finally:
        ctx.close()


def emulator(server, model: str) -> dict:
    return server.get("/api/devices")["simulated_rig"]["emulators"][model]


RESTARTED: dict[str, subprocess.Popen] = {}  # the emulators this module started again (the rig knows the first)


def restart(server, model: str) -> None:
    """Start `model`'s emulator again at its link, as the rig would (devices/rig.py)."""
    info = emulator(server, model)
    rig = server.get("/api/devices")["simulated_rig"]["directory"]
    RESTARTED[model] = subprocess.Popen(emulator_command(model, Path(info["link"]), Path(rig) / f"{model}-timeline.csv",
                                      append_timeline=True),  # exits with this test process at the latest
                     cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wait_for(lambda: next(d for d in server.get("/api/devices")["devices"] if d["name"] == model)["status"]
             == "connected", timeout=20, what=f"{model} connected again")


def kill(server, model: str) -> None:
    again = RESTARTED.pop(model, None)
    if again is not None:
        again.kill()
        again.wait()
    else:
        os.kill(emulator(server, model)["pid"], signal.SIGKILL)


def test_the_devices_panel_shows_each_device_and_what_the_scenario_needs(console):
    view = console.page.evaluate("window.__console.devices()")
    rows = {r["name"]: r for r in view["rows"]}
    assert set(rows) == {"fingertac", "ferrovibe"}
    assert all(r["status"] == "connected" and r["framesOut"] > 0 for r in rows.values())
    assert rows["ferrovibe"]["need"]["needed"] and not rows["fingertac"]["need"]["needed"]
    panel = console.text("#devices-panel")
    assert "contact-angle-v1 shows macro-roughness (direct) on it" in panel
    assert "watchdog trips:" in panel and "link:" in panel


def test_a_killed_emulator_shows_in_the_console_within_1_s(console, server):
    page = console.page
    try:
        kill(server, "ferrovibe")
        t0 = time.monotonic()
        page.wait_for_function("() => { const b = document.querySelector('#health-banner'); "
                               "return !!b && !b.hidden && b.innerText.includes(\"'ferrovibe'\"); }",
                               timeout=5000, polling=50)
        shown_s = time.monotonic() - t0
        page.wait_for_function("() => document.querySelector('#devices-panel li[data-device=\"ferrovibe\"]')"
                               "?.dataset.status === 'bad'", timeout=5000, polling=50)
        page.screenshot(path=str(ARTIFACTS / "panels-device-killed.png"))
        assert "disconnected" in console.text("#devices-panel li[data-device=\"ferrovibe\"]")
        assert shown_s <= 1.0, f"the banner named the killed device after {shown_s:.2f} s"
    finally:
        restart(server, "ferrovibe")
    page.wait_for_function("() => document.querySelector('#devices-panel li[data-device=\"ferrovibe\"]')"
                           "?.dataset.status === 'ok'", timeout=10_000)


def test_a_trial_started_without_its_device_is_flagged_in_the_queue(console, server):
    study = "thesis-2021"  # its first trial runs on the simulated rig's devices (the batteries' may not)
    session = server.post("/api/sessions", {"study": study, "participant": "P77", "experimenter": "test"})
    sid = session["id"]

    def trial_action(seq: int, action: str, query: str = "", body: dict | None = None) -> dict:
        req = urllib.request.Request(f"{server.http_url}/api/sessions/{sid}/trials/{seq}/{action}{query}",
                                     method="POST", data=json.dumps(body or {}).encode(),
                                     headers={"Content-Type": "application/json", "X-Control-Token": session["token"],
                                              **auth_headers(server.http_url)})
        with urllib.request.urlopen(req, timeout=30) as answer:
            return json.loads(answer.read())

    view = server.get(f"/api/sessions/{sid}")
    first = view["next"]
    scenario = resolve(next(t for t in view["trials"] if t["seq"] == first)["scenario"]).id
    device = next(s for s in server.get("/api/scenarios") if s["id"] == scenario)["capability"]["usable"][0]
    try:
        kill(server, device)
        wait_for(lambda: next(d for d in server.get("/api/devices")["devices"] if d["name"] == device)["status"]
                 != "connected", timeout=10, what=f"{device} gone")
        with pytest.raises(urllib.error.HTTPError) as refused:
            trial_action(first, "start")
        assert refused.value.code == 409  # the device it needs is off
        trial_action(first, "start", "?force=true")  # the API's way past it: the trial is flagged
        trial_action(first, "abort", body={"reason": "device off"})
    finally:
        restart(server, device)
    trial = next(t for t in server.get(f"/api/sessions/{sid}")["trials"] if t["seq"] == first)
    assert trial["device_off"] == [device], trial
    console.page.goto("about:blank")  # a new load (a fragment change alone reloads nothing)
    console.open(f"#session={sid}")
    row = f"#queue tr[data-seq=\"{first}\"]"
    console.page.wait_for_selector(f"{row} .c-device-off", timeout=10_000)
    assert f"{device} off" in console.text(f"{row} .c-device-off")
    console.page.screenshot(path=str(ARTIFACTS / "panels-queue-device-off.png"))


def test_the_scenario_card_switches_with_declared_parameters_and_says_refusals_in_button_words(console, server):
    page = console.page
    page.click("#scenario-details summary")
    page.wait_for_selector("#scenario-choice")
    page.select_option("#scenario-choice", "texture-v1")
    page.wait_for_selector("#scenario-param-velocity")
    assert page.get_attribute("#scenario-param-velocity", "min") == "-2"
    assert page.get_attribute("#scenario-param-velocity", "max") == "2"
    assert page.eval_on_selector_all("#scenario-param-period_us option", "os => os.map(o => o.textContent)") == [
        "2000", "3000", "4000", "5000", "6000"]
    page.fill("#scenario-param-velocity", "5")
    page.click("#scenario-switch")
    console.wait_text("#scenario-msg", "velocity: 5 is outside -2 – 2 units/s")
    assert server.get("/api/scenario")["id"] == "contact-angle-v1", "nothing sent"

    server.delete("/api/lease")  # the harness's admin (this console's token) gives the rig up
    try:
        page.fill("#scenario-param-velocity", "0.5")
        page.click("#scenario-switch")
        console.wait_text("#scenario-msg", "Not switched")
        said = console.text("#scenario-msg")
        assert "“Request control”" in said and "/api/" not in said, said
        assert page.inner_text("#lease-summary") == "Nobody controls the rig"
    finally:
        server.post("/api/lease")
    page.click("#scenario-switch")
    console.wait_text("#scenario-msg", "Switched to")
    running = server.get("/api/scenario")
    assert running["id"] == "texture-v1" and running["params"]["velocity"] == 0.5
    console.wait_text("#scenario-running", "texture-v1")
    page.screenshot(path=str(ARTIFACTS / "panels-scenario.png"))
    server.post("/api/scenario", {"name": "contact-angle"})  # as the module found it


def test_the_header_names_session_control_and_the_rig_lease_apart(console, server):
    page = console.page
    assert page.inner_text("#take-control") == "Take control of this session"
    assert page.inner_text("#lease-request" if page.is_visible("#lease-request") else "#lease-summary")
    server.delete("/api/lease")
    try:
        page.wait_for_selector("#lease-request", timeout=10_000)
        assert page.inner_text("#lease-request") == "Request control"
    finally:
        server.post("/api/lease")


def test_starting_without_the_rig_lease_names_the_button_and_keeps_session_control(console, server):
    study = server.get("/api/studies")[0]["id"]
    sid = server.post("/api/sessions", {"study": study, "participant": "P78", "experimenter": "test"})["id"]
    page = console.page
    page.goto("about:blank")
    console.open(f"#session={sid}")
    page.fill("#experimenter", "tester")
    page.click("#take-control")  # the session's control, which the API's creator held
    console.wait_state("s.control === 'yes'")
    assert page.inner_text("#control-text") == "You control this session"
    server.delete("/api/lease")
    try:
        console.wait_text("#control-text", "not the rig")
        assert "“Request control”" in page.inner_text("#control-text")
        page.wait_for_selector("#start:not([disabled])")
        page.click("#start")
        console.wait_text("#run-msg", "Request control")
        said = page.inner_text("#run-msg")
        assert "/api/" not in said and "POST" not in said, said
        assert console.state()["control"] == "yes", "a lease refusal is not a lost session"
        assert not page.inner_text("#control-text").startswith("Session control lost")
        page.screenshot(path=str(ARTIFACTS / "panels-start-without-lease.png"))
    finally:
        server.post("/api/lease")
    console.wait_text("#control-text", "You control this session")


@pytest.mark.parametrize("path, rendered", [
    ("/docs", "document.querySelectorAll('.opblock').length > 10"),
    ("/redoc", "document.querySelectorAll('[data-section-id^=\"operation\"], [id^=\"operation/\"]').length > 10"),
])
def test_the_api_docs_work_offline(browser, server, path, rendered):
    """Every request to another host than the server is aborted (a lab network without internet)."""
    require_web_deps()
    ctx = new_context(browser, server.http_url, viewport=CONSOLE_VIEWPORT, bypass_csp=False)
    own = urlparse(server.http_url).netloc
    outside: list[str] = []

    def only_the_server(route):
        url = urlparse(route.request.url)
        if url.scheme in ("http", "https", "ws", "wss") and url.netloc != own:
            outside.append(route.request.url)
            return route.abort()
        return route.continue_()

    try:
        ctx.route("**/*", only_the_server)
        page = ctx.new_page()
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(server.http_url + path)
        # under the page's own Content-Security-Policy (wait_for_function would need 'unsafe-eval')
        wait_for(lambda: page.evaluate(rendered), timeout=30, what=f"{path} rendered")
        page.screenshot(path=str(ARTIFACTS / f"panels-{path.strip('/')}.png"))
        assert not outside, outside
        assert not errors, errors
    finally:
        ctx.close()


def teardown_module():
    for proc in RESTARTED.values():  # started here, so stopped here
        proc.kill()
        proc.wait()
    RESTARTED.clear()
