"""Browser actuators (issue 37 point 4) in headless Chromium: the participant page's own actuators as
the rig's `browser` device (`serve --rig browser`; devices/browser.py, clients/web/src/actuators.js).

(a) the emulated headset (iwer, Meta Quest 3) in controller mode: the controller's ray touches the
    contact-angle dome and that controller's haptic actuator `pulse`s (instrumented: every call is
    recorded with the page's rendered frame and the newest state's tick) at the tilt's magnitude,
    in the first frame the page renders after the state frame that carries the cue;
(b) an emulated gamepad (a Gamepad whose `vibrationActuator.playEffect` records its calls) rumbles
    for the free scenario's contact vibration, and stops when the contact ends;
(c) the capability check refuses a scenario the actuator cannot show (texture: no texture period),
    with the reason, while the dome's tilt is shown as its magnitude;
(d) tracked hands: no actuator; the page says so and the device is disconnected, with the reason.
"""

from __future__ import annotations

import socket
import threading
import time
import urllib.error

import msgpack
import numpy as np
import pytest

from tests.live_server import get_json, start_server, stop_server
from tests.browser.conftest import new_context, require_web_deps
from tests.browser.test_web_client import wait_for
from tests.browser.test_xr import (HEAD_AT, HEAD_PITCH_DEG, PLACEMENT, SETUP, VIEWPORT, on_dome)

pytestmark = pytest.mark.browser

MAGNITUDE_PCT = 60.0  # the contact-angle tilt's magnitude: the pulse's value must be 0.6


@pytest.fixture(scope="module")
def browser_rig():
    """A server whose rig is the participant's page alone, running free exploration (it needs no
    device, so the server is healthy before any page offers an actuator)."""
    proc, base = start_server("free-v1", ["--rig", "browser"])
    try:
        assert get_json(base + "/api/placement/rig", "PUT", body=PLACEMENT)["rig"] == PLACEMENT
        yield base
    finally:
        stop_server(proc)


def browser_device(base: str) -> dict:
    return next(d for d in get_json(base + "/api/devices")["devices"] if d["name"] == "browser")


def switch(base: str, name: str, params: dict | None = None, force: bool = False):
    return get_json(base + "/api/scenario", "POST", body={"name": name, "params": params or {}, "force": force})


def open_page(browser, base: str, query: str = "", init_script: str | None = None):
    require_web_deps()
    ctx = new_context(browser, base, viewport=VIEWPORT)
    if init_script:
        ctx.add_init_script(init_script)
    page = ctx.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(base + "/" + query)
    page.wait_for_function("window.__viestac && window.__viestac.ready", timeout=20_000)
    return ctx, page, errors


# The driving controller's ray, moved so that its tip (5 cm along the ray: xr_hands.js controllerSample)
# lands on a scene point; the controller points straight ahead (-z), as a hand holding it would.
AIM = """([scene]) => { const v = window.__viestac; const d = v.xrDevice, xr = v.xr; const ray = xr.controllerRay;
    const c = d.controllers[ray.hand]; const target = xr.toXr(scene);
    const tip = ray.origin.map((o, i) => o + ray.dir[i] * 0.05);
    c.position.set(c.position.x + target[0] - tip[0], c.position.y + target[1] - tip[1], c.position.z + target[2] - tip[2]); }"""
RAY_TIP = """(() => { const r = window.__viestac.xr.controllerRay;
    return r ? r.origin.map((o, i) => o + r.dir[i] * 0.05) : null; })()"""
# Every pulse of every controller, recorded with the page's rendered frame and the newest state's tick.
INSTRUMENT = """() => { const v = window.__viestac; window.__pulses = [];
    for (const source of v.xr.session.inputSources) {
      const a = source.gamepad && source.gamepad.hapticActuators[0];
      if (!a || a.__recorded) continue;
      const pulse = a.pulse.bind(a);
      a.pulse = (value, ms) => { window.__pulses.push({hand: source.handedness, value, ms, frame: v.actuators.frames,
                                                     tick: v.actuators.tick, t: performance.now()});
                                 return pulse(value, ms); };
      a.__recorded = true;
    } }"""


def aim(page, scene_pos, tol=1e-4) -> None:
    for _ in range(3):  # the ray's offset from the controller's position is exact after the first step
        page.evaluate(AIM, [scene_pos])
        page.wait_for_timeout(60)
    target = page.evaluate("(p) => window.__viestac.xr.toXr(p)", scene_pos)
    wait_for(lambda: np.allclose(page.evaluate(RAY_TIP), target, atol=tol), timeout=5, what="the ray's tip at its target")


def enter_xr(page, mode: str) -> None:
    page.evaluate(f"window.__viestac.xrDevice.primaryInputMode = '{mode}'")
    page.evaluate(SETUP, [HEAD_AT, HEAD_PITCH_DEG, [-0.45, 0.9, 0.1]])
    page.click("#xr button[data-mode=immersive-vr]")
    page.wait_for_function("window.__viestac.xr.active && window.__viestac.xr.stats.frames > 5", timeout=20_000)


def test_a_touch_on_the_dome_pulses_the_controller_scaled_by_the_cue_within_a_frame(browser, browser_rig):
    base = browser_rig
    ctx, page, errors = open_page(browser, base, "?xr_emulator=quest3&xr_ttl=400")
    try:
        enter_xr(page, "controller")
        wait_for(lambda: browser_device(base)["status"] == "connected", timeout=5, what="the page's controllers offered")
        device = browser_device(base)
        assert sorted(map(tuple, device["pages"][0]["actuators"])) == [("xr", "left"), ("xr", "right")]
        assert device["profile"]["model"] == "browser" and device["profile"]["table_2_2"]["macro_roughness"] == "(!)"
        health = get_json(base + "/api/health")
        assert all(r["code"] != "device_missing" for r in health.get("reasons", [])), health

        # the contact-angle task on the browser device alone: its tilt is shown as its magnitude
        assert switch(base, "contact-angle", {"magnitude_pct": MAGNITUDE_PCT})
        wait_for(lambda: get_json(base + "/api/scenario")["id"] == "contact-angle-v1", timeout=10, what="the switch")
        page.wait_for_function("window.__viestac.xr.controllerRay !== undefined && window.__viestac.xr.controllerRay",
                               timeout=5000)
        angle = -30.0
        aim(page, on_dome(angle, 0.3))
        wait_for(lambda: get_json(base + "/api/state")["tools"][0]["hip"][2] > 0.6, timeout=5,
                 what="the controller drives the HIP above the dome")
        assert not get_json(base + "/api/state")["contact"]
        page.evaluate(INSTRUMENT)
        assert page.evaluate("window.__viestac.actuators.drive[0]") == 0, "no cue before the touch"

        for out in np.linspace(0.3, -0.03, 9):  # a scripted approach along the normal into the dome
            page.evaluate(AIM, [on_dome(angle, float(out))])
            page.wait_for_timeout(45)
        aim(page, on_dome(angle, -0.03))
        wait_for(lambda: get_json(base + "/api/state")["contact"], timeout=5, what="contact in the server's state")
        wait_for(lambda: page.evaluate("window.__pulses.some((p) => p.value > 0)"), timeout=3, what="a pulse")

        state = get_json(base + "/api/state")
        assert state["actuator"][0] == pytest.approx(MAGNITUDE_PCT / 100), state["actuator"]
        assert state["cues"][0]["kind"] == "tilt" and state["cues"][0]["magnitude_pct"] == MAGNITUDE_PCT
        changes = page.evaluate("window.__viestac.actuators.changes")
        carried = next(c for c in changes if c[3] and c[3][0] > 0)  # the first state frame that carried the cue
        frames_before, tick = carried[1], carried[2]
        pulses = page.evaluate("window.__pulses")
        first = next(p for p in pulses if p["value"] > 0)
        assert first["value"] == pytest.approx(MAGNITUDE_PCT / 100), "scaled by the cue: the tilt's magnitude"
        assert first["tick"] >= tick and first["frame"] == frames_before + 1, \
            f"the state of tick {tick} arrived after frame {frames_before}; first pulse {first}"
        assert 0 < first["ms"] <= 100
        driving = page.evaluate("window.__viestac.xr.drivingHand")
        assert {p["hand"] for p in pulses if p["value"] > 0} == {driving}, "only the controller that drives the HIP"
        # held: it pulses in every rendered frame, at the same value
        time.sleep(0.3)
        held = [p for p in page.evaluate("window.__pulses") if p["value"] > 0]
        frames = [p["frame"] for p in held]
        assert len(held) >= 3 and frames == sorted(set(frames)), "one pulse a rendered frame"
        assert all(p["value"] == pytest.approx(MAGNITUDE_PCT / 100) for p in held)

        # the controller leaves: the actuator stops (one pulse of 0), and no pulse of a value follows
        aim(page, on_dome(angle, 0.3))
        wait_for(lambda: not get_json(base + "/api/state")["contact"], timeout=5, what="contact to end")
        wait_for(lambda: page.evaluate("window.__pulses.at(-1).value") == 0, timeout=3, what="the pulse to stop")
        page.evaluate("window.__viestac.xr.exit()")
        page.wait_for_function("!window.__viestac.xr.active", timeout=5000)
        assert not errors, errors
    finally:
        ctx.close()
        switch(base, "free-v1")


GAMEPAD = """(() => { window.__rumbles = [];
  const actuator = { type: 'dual-rumble',
    playEffect(kind, p) { window.__rumbles.push({kind, ...p, t: performance.now()}); return Promise.resolve('complete'); },
    reset() { window.__rumbles.push({kind: 'reset', t: performance.now()}); return Promise.resolve('complete'); } };
  const pad = { id: 'Emulated gamepad (STANDARD GAMEPAD)', index: 0, connected: true, mapping: 'standard',
                timestamp: 0, axes: [0, 0, 0, 0], buttons: [], vibrationActuator: actuator };
  Object.defineProperty(navigator, 'getGamepads', { value: () => [pad, null, null, null], configurable: true });
})();"""


def hold_in_contact(tracker_udp: str, pos: list[float], stop: threading.Event) -> None:
    """A tracker bridge on the loop's UDP port holding the HIP at `pos` (60 Hz; each sample good for
    60 ms, so the HIP goes home when it stops)."""
    host, port = tracker_udp.rsplit(":", 1)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        seq = 0
        while not stop.is_set():
            sock.sendto(msgpack.packb({"type": "tracker", "seq": seq, "t": time.monotonic() * 1e3, "pos": pos,
                                      "ttl": 60}),
                        (host, int(port)))
            seq += 1
            stop.wait(1 / 60)


def test_an_emulated_gamepad_rumbles_for_a_vibration_cue(browser, browser_rig):
    base = browser_rig
    ctx, page, errors = open_page(browser, base, init_script=GAMEPAD)
    stop = threading.Event()
    bridge = None
    try:
        wait_for(lambda: browser_device(base)["status"] == "connected", timeout=5, what="the gamepad offered")
        assert browser_device(base)["pages"][-1]["actuators"] == [["gamepad", "none"]]
        assert get_json(base + "/api/scenario")["id"] == "free-v1"
        assert page.evaluate("window.__rumbles.length") == 0, "no cue, no rumble"
        # the HIP pushed into the sandbox's box (top at z = 0.6): free exploration vibrates at 100 %
        bridge = threading.Thread(target=hold_in_contact, args=(get_json(base + "/api/health")["tracker_udp"],
                                                                [0.0, 0.0, 0.58], stop), daemon=True)
        bridge.start()
        wait_for(lambda: get_json(base + "/api/state")["contact"], timeout=5, what="contact with the box")
        wait_for(lambda: page.evaluate("window.__rumbles.some((r) => r.strongMagnitude > 0)"), timeout=3,
                 what="the gamepad to rumble")
        rumble = page.evaluate("window.__rumbles.find((r) => r.strongMagnitude > 0)")
        assert rumble["kind"] == "dual-rumble" and rumble["strongMagnitude"] == 1.0 == rumble["weakMagnitude"]
        assert 0 < rumble["duration"] <= 100 and rumble["startDelay"] == 0
        assert get_json(base + "/api/state")["actuator"][:4] == [1.0, 0, 0, 0]
        stop.set()
        bridge.join()
        wait_for(lambda: not get_json(base + "/api/state")["contact"], timeout=5, what="the tracker to go")
        wait_for(lambda: page.evaluate("window.__rumbles.at(-1).kind") == "reset", timeout=3, what="the rumble to stop")
        assert not errors, errors
    finally:
        stop.set()
        ctx.close()
    wait_for(lambda: browser_device(base)["status"] == "disconnected", timeout=5, what="the page gone: disconnected")


def test_the_capability_check_refuses_what_a_browser_actuator_cannot_show(browser_rig):
    base = browser_rig
    with pytest.raises(urllib.error.HTTPError) as refused:
        switch(base, "texture")
    text = refused.value.read().decode()
    assert refused.value.code == 409 and "texture" in text, text
    assert "cannot show the texture cue: its profile does not display fine-roughness" in text, text
    scenario = get_json(base + "/api/scenario")
    assert scenario["id"] == "free-v1", "the refused switch changed nothing"
    # what the profile says it shows: a tilt by its magnitude (contact-angle), never a texture period
    device = browser_device(base)
    assert device["profile"]["table_2_2"] == {"stiffness": "(!)", "macro_roughness": "(!)", "fine_roughness": "-",
                                              "temperature": "-", "friction": "-"}
    assert device["profile"]["carrier_hz"] == 0 and device["profile"]["caps"] == ["continuous", "pulse"]


def test_tracked_hands_offer_no_actuator_and_say_so(browser, browser_rig):
    base = browser_rig
    ctx, page, errors = open_page(browser, base, "?xr_emulator=quest3&xr_ttl=400")
    try:
        enter_xr(page, "hand")
        wait_for(lambda: browser_device(base)["pages"], timeout=5, what="the page's offer")
        device = browser_device(base)
        assert device["status"] == "disconnected"
        assert device["pages"][-1] == {"client_id": device["pages"][-1]["client_id"], "actuators": [],
                                       "note": "tracked hands have no actuator"}
        assert "tracked hands have no actuator" in device["last_error"]
        assert page.evaluate("window.__viestac.actuators.offer()") == {"actuators": [],
                                                                        "note": "tracked hands have no actuator"}
        assert page.evaluate("window.__viestac.actuators.log.length") == 0, "nothing to pulse"
        # the participant is told too, on the XR panel
        wait_for(lambda: "Tracked hands have no actuator: hold the controllers to feel the cues" in
                 page.evaluate("window.__viestac.xr.panel.lines"), timeout=3, what="the panel to say so")
        # a scenario that needs the device: health names it missing
        assert switch(base, "contact-angle", force=True)
        reason = wait_for(lambda: next((r for r in get_json(base + "/api/health").get("reasons", [])
                                        if r["code"] == "device_missing" and "'browser'" in r["message"]), None),
                          timeout=5, what="health to name the browser device missing")
        assert "the participant's page offers no actuator (hold the controllers: tracked hands have none)" in \
            reason["message"] and "cable" not in reason["message"], reason
        page.evaluate("window.__viestac.xr.exit()")
        assert not errors, errors
    finally:
        ctx.close()
        switch(base, "free-v1")
