"""WebXR in headless Chromium with the Immersive Web Emulation Runtime (npm `iwer`): an emulated
Meta Quest 3 in hand-tracking mode (clients/web/src/xr_emulator.js, loaded by ?xr_emulator=quest3)
enters an immersive-vr session from the participant page; a scripted hand motion brings the
emulated right index fingertip onto the contact-angle hemisphere. The server must see the contact
and the FerroVibe emulator must tilt toward the touched angle (within 2°); the page draws the
fingertip held on the surface at the proxy (visual god-object): predicted in the frame that read
the pose inside, then the server's proxy. Screenshots of both eyes are saved
in tests/artifacts/browser/.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from devices.emulator import Emulator
from tests.live_server import get_json, start_server, stop_server
from tests.browser.conftest import ARTIFACTS, new_context, require_web_deps
from tests.browser.test_web_client import screenshot_pixels, wait_for

pytestmark = pytest.mark.browser

VIEWPORT = {"width": 1200, "height": 600}
# Where the scene stands: a table top 1.2 m up, 0.5 m in front of the emulated headset (at 1.6 m),
# one scene unit = 10 cm (the dome's radius, 0.6 units, is 6 cm).
PLACEMENT = {"table_height_m": 1.2, "origin_m": [0.0, -0.5], "yaw_deg": 0.0, "scale_m_per_unit": 0.1}
DOME_R, PROXY_R = 0.6, 0.06  # scenarios/contact_angle.py: dome radius, the HIP's proxy radius
HEAD_AT, HEAD_PITCH_DEG = [0.0, 1.45, -0.15], -40.0  # the emulated head leans over the table, looking down
LEFT_HAND_AWAY = [-0.45, 0.9, 0.1]  # the left hand hangs by the side


def on_dome(angle_deg: float, out: float) -> list[float]:
    """A scene point at contact angle `angle_deg` (Algorithm 1), `out` outside the proxy-dilated
    dome (negative: inside)."""
    r = DOME_R + PROXY_R + out
    a = math.radians(angle_deg)
    return [0.0, r * math.sin(a), r * math.cos(a)]


@pytest.fixture(scope="module")
def xr_rig(tmp_path_factory):
    """A server running contact-angle with a FerroVibe emulator on the index (like
    tests/integration/test_fingers_live.py) and the rig's placement stored."""
    tmp = tmp_path_factory.mktemp("xr")
    emulator = Emulator("ferrovibe", link=tmp / "index")
    emulator.start()
    proc, base = start_server("contact-angle", ["--device", f"index=ferrovibe@{tmp / 'index'}"])
    try:
        assert get_json(base + "/api/placement/rig", "PUT", body=PLACEMENT)["rig"] == PLACEMENT
        yield emulator, base
    finally:
        stop_server(proc)
        emulator.stop()


@pytest.fixture
def xr_page(browser, xr_rig):
    require_web_deps()
    _, base = xr_rig
    ctx = new_context(browser, base, viewport=VIEWPORT)
    page = ctx.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(base + "/?xr_emulator=quest3&xr_ttl=400")
    page.wait_for_function("window.__viestac && window.__viestac.ready && window.__viestac.xrDevice", timeout=20_000)
    yield page, errors
    ctx.close()


# The emulated head pitched down; the right hand moved so that its index tip lands on a target
# (the hand is rigid: one offset from the hand's position to its tip, measured once).
SETUP = """([head, pitch, left]) => { const d = window.__viestac.xrDevice; const a = pitch * Math.PI / 360;
    d.position.set(...head); d.quaternion.set(Math.sin(a), 0, 0, Math.cos(a)); d.hands.left.position.set(...left); }"""
MOVE = """([scene]) => { const v = window.__viestac; const d = v.xrDevice, xr = v.xr;
    const tip = xr.joints.right['index-finger-tip']; const h = d.hands.right.position;
    const target = xr.toXr(scene);
    d.hands.right.position.set(h.x + target[0] - tip[0], h.y + target[1] - tip[1], h.z + target[2] - tip[2]); }"""
TIP = "window.__viestac.xr.joints.right && window.__viestac.xr.joints.right['index-finger-tip']"


def move_tip(page, scene_pos, tol=1e-4) -> None:
    """Move the emulated index fingertip to a scene point and wait until the page's frames see it there."""
    for _ in range(3):  # the hand's offset to its tip is exact after the first step; frames may lag
        page.evaluate(MOVE, [scene_pos])
        page.wait_for_timeout(60)
    xr_target = page.evaluate("(p) => window.__viestac.xr.toXr(p)", scene_pos)
    wait_for(lambda: np.allclose(page.evaluate(TIP), xr_target, atol=tol), timeout=5, what="the fingertip at its target")


def tilt_edges(emulator: Emulator, since_us: int = 0) -> list:
    return [e for e in emulator.snapshot_edges() if e.t_us >= since_us and e.magnitude > 0]


def test_emulated_hand_touches_the_dome_contact_and_tilt(xr_page, xr_rig):
    page, errors = xr_page
    emulator, base = xr_rig
    buttons = page.evaluate("[...document.querySelectorAll('#xr button')].map((b) => b.dataset.mode)")
    assert "immersive-vr" in buttons
    page.evaluate(SETUP, [HEAD_AT, HEAD_PITCH_DEG, LEFT_HAND_AWAY])
    page.click("#xr button[data-mode=immersive-vr]")
    page.wait_for_function("window.__viestac.xr.active && window.__viestac.xr.stats.frames > 5 && "
                           "window.__viestac.xr.joints.right", timeout=20_000)
    assert page.evaluate("window.__viestac.xr.phase") == "running", "the rig's placement is used: no placement step"
    assert page.evaluate("Object.keys(window.__viestac.xr.joints.right).length") == 25

    # the hand above the dome: tracked (every joint a point), no contact
    angle = -30.0
    move_tip(page, on_dome(angle, 0.3))
    # SwiftShader draws a frame in 50-100 ms on a busy machine: a sample is good for 400 ms
    # (?xr_ttl=400; a headset's 100 ms default would call the hand lost between frames here)
    wait_for(lambda: (lambda s: s["tools"][0]["hip"][2] > DOME_R and len(s["points"]) == 49)(get_json(base + "/api/state")),
             timeout=5, what="the hand tracked")
    state = get_json(base + "/api/state")
    right = [n for n in state["points"] if n.startswith("right.")]
    assert not state["contact"] and len(right) == 24, "the index tip drives the HIP; the right hand's 24 other joints drawn"
    assert len(state["points"]) == 24 + 25, "the left hand's 25 joints come too (drawn only)"
    assert not tilt_edges(emulator)

    # a scripted approach along the normal into the dome: 0.3 units out to 0.03 in, ~0.4 s
    since_us = time.monotonic_ns() // 1000
    t_approach = page.evaluate("performance.now()")
    for out in np.linspace(0.3, -0.03, 9):
        page.evaluate(MOVE, [on_dome(angle, float(out))])
        page.wait_for_timeout(45)
    move_tip(page, on_dome(angle, -0.03))
    wait_for(lambda: get_json(base + "/api/state")["contact"], timeout=5, what="contact in the server's state")

    # the frame that read the first pose inside drew the fingertip on the surface already, from
    # the client's copy of the scene (predicted), before any state of the server said contact
    log = page.evaluate("(() => { const l = window.__viestac.xr.log; return {samples: l.samples, draws: l.draws, states: l.states}; })()")
    first_in = next(s for s in log["samples"] if s[1] >= t_approach and np.linalg.norm(s[2]) < DOME_R + PROXY_R)
    drawn = next(d for d in log["draws"] if d[0] >= first_in[1] and d[1])
    assert drawn[2] == first_in[3] and drawn[3] == "predicted", f"pose in frame {first_in[3]}, drawn {drawn}"
    assert abs(np.linalg.norm(drawn[4]) - (DOME_R + PROXY_R)) < 1e-9, "drawn on the proxy-offset dome"
    confirmed = next(s for s in log["states"] if s[0] >= first_in[1] and s[1])
    assert confirmed[0] > drawn[0], "the server's contact came after that frame was drawn"
    wait_for(lambda: page.evaluate("window.__viestac.xr.drawnPredicted.length === 0 && "
                                   "window.__viestac.xr.drawnHeld.includes('right.index.tip')"),
             timeout=3, what="the server's proxy replacing the prediction")
    state = get_json(base + "/api/state")
    assert abs(state["values"]["angle_deg"] - angle) < 2.0, state["values"]
    wait_for(lambda: tilt_edges(emulator, since_us), timeout=3, what="the FerroVibe to tilt")
    time.sleep(0.15)  # held, as a hand would: the device shows the newest cue
    tilt = tilt_edges(emulator, since_us)[-1]
    direction = tilt.direction_cdeg / 100.0
    assert abs((direction - (-angle) % 360 + 180) % 360 - 180) < 2.0, f"tilt toward {direction}°, touched {angle}°"

    # the drawn fingertip stays on the surface at the proxy while the real one is inside
    wait_for(lambda: "right.index.tip" in page.evaluate("window.__viestac.xr.drawnHeld"), what="the tip held at the proxy")
    proxy = np.array(state["proxy"])
    assert abs(np.linalg.norm(proxy) - (DOME_R + PROXY_R)) < 0.005, "the proxy is on the dilated dome"
    assert np.linalg.norm(np.array(state["hip"])) < DOME_R + PROXY_R - 0.02, "the real finger is inside"

    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    png = page.screenshot(path=str(ARTIFACTS / "xr_contact_angle_both_eyes.png"))
    px = screenshot_pixels(page, png)[:, :, :3].astype(float)
    h, w, _ = px.shape
    left, right = px[:, : w // 2], px[:, w // 2:]
    def blue(eye):  # the dome's pixels (#3a7bd5, lit): blue well above red
        return (eye[:, :, 2] > eye[:, :, 0] + 60) & (eye[:, :, 2] > 120)

    seen = [blue(left), blue(right)]
    assert all(m.mean() > 0.005 for m in seen), f"the dome is seen by both eyes: {[m.mean() for m in seen]}"
    cx = [np.nonzero(m)[1].mean() / m.shape[1] for m in seen]
    assert 0 < cx[0] - cx[1] < 0.1, f"the eyes see it from two points (a small disparity): {cx}"
    assert not errors, errors

    # the hand leaves: no contact, the device flat again
    move_tip(page, on_dome(angle, 0.3))
    wait_for(lambda: not get_json(base + "/api/state")["contact"], timeout=5, what="contact to end")
    wait_for(lambda: emulator.snapshot_edges()[-1].magnitude == 0, timeout=3, what="the FerroVibe flat again")

    # the placement step again: the fingertip held still for the count-down places the scene there
    page.evaluate("window.__viestac.xr.place()")
    held = page.evaluate(TIP)
    wait_for(lambda: page.evaluate("window.__viestac.xr.phase") == "running", timeout=8, what="the placement step to end")
    placed = page.evaluate("window.__viestac.xr.placement")
    assert abs(placed["table_height_m"] - held[1]) < 1e-6 and np.allclose(placed["origin_m"], [held[0], held[2]], atol=1e-6)
    page.screenshot(path=str(ARTIFACTS / "xr_after_placement_step.png"))
    page.evaluate("window.__viestac.xr.exit()")
    page.wait_for_function("!window.__viestac.xr.active", timeout=5000)
    assert not errors, errors
