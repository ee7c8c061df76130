"""`viestac bench xr`: the WebXR client in an emulated headset (docs/xr.md "Timing").

Headless Chromium (Debian's /usr/bin/chromium through Playwright, WebGL on SwiftShader) opens the
participant page with the Immersive Web Emulation Runtime (?xr_emulator=quest3: an emulated Meta
Quest 3, hand tracking, both eyes) against a server running contact-angle with a FerroVibe
emulator on the index. It enters immersive-vr and measures:

- **frame rate** of the session: XR frames drawn per second over `seconds` (the headset's own
  rate would be 72-120 Hz; here it is what SwiftShader manages on this machine's CPU);
- **hand pose → proxy drawn**: the emulated fingertip jumps from 0.3 scene units above the
  dome to 0.03 inside it, `touches` times. From the XR frame that read the first joint pose
  inside (and sent it) to the end of the first XR frame that draws the fingertip held at the
  proxy (page clock);
- **hand pose → device command**: from that same frame to the FerroVibe emulator's first edge
  that tilts (CLOCK_MONOTONIC; the page's clock is mapped onto it by the tightest of 30
  evaluate round trips, ±half that round trip);
- **tactile leads picture**: the edge's time minus the drawn frame's (positive: the device moved
  first). The budget is 15 ms (haptic-before-visual asynchrony is noticed from about 15 ms,
  Di Luca & Mahnan 2019). A real headset adds its display's scan-out (~1 frame) to the picture.
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

from server.bench.loop_bench import get_json, start_server, stop_server
from server.bench.quantiles import tail

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless=new", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run"]
PLACEMENT = {"table_height_m": 1.2, "origin_m": [0.0, -0.5], "yaw_deg": 0.0, "scale_m_per_unit": 0.1}
DOME_R, PROXY_R = 0.6, 0.06  # scenarios/contact_angle.py
ANGLES = (-60.0, -30.0, 0.0, 30.0, 60.0)

SETUP = """() => { const d = window.__viestac.xrDevice; const a = -40 * Math.PI / 360;
    d.position.set(0, 1.45, -0.15); d.quaternion.set(Math.sin(a), 0, 0, Math.cos(a)); d.hands.left.position.set(-0.45, 0.9, 0.1); }"""
MOVE = """([scene]) => { const v = window.__viestac; const d = v.xrDevice, xr = v.xr;
    const tip = xr.joints.right['index-finger-tip']; const h = d.hands.right.position;
    const target = xr.toXr(scene);
    d.hands.right.position.set(h.x + target[0] - tip[0], h.y + target[1] - tip[1], h.z + target[2] - tip[2]); }"""
PAGE_NOW = "performance.timeOrigin + performance.now()"


def on_dome(angle_deg: float, out: float) -> list[float]:
    r = DOME_R + PROXY_R + out
    a = math.radians(angle_deg)
    return [0.0, r * math.sin(a), r * math.cos(a)]


def _clock_offset_ns(page, rounds: int = 30) -> tuple[float, float]:
    """(CLOCK_MONOTONIC ns − page ms × 1e6, half the round trip in ms) from the tightest round trip."""
    best = None
    for _ in range(rounds):
        t0 = time.monotonic_ns()
        p = page.evaluate(PAGE_NOW)
        t1 = time.monotonic_ns()
        if best is None or t1 - t0 < best[0]:
            best = (t1 - t0, (t0 + t1) / 2 - p * 1e6)
    return best[1], best[0] / 2e6


def _wait(predicate, timeout_s: float, what: str):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.01)
    raise RuntimeError(f"timed out waiting for {what}")


def run_xr_bench(touches: int = 20, seconds: float = 5.0) -> dict:
    from devices.emulator import Emulator
    from playwright.sync_api import sync_playwright

    from server.bench.loop_bench import admin_token

    tmp = Path(tempfile.mkdtemp(prefix="viestac-xr-bench-"))
    emulator = Emulator("ferrovibe", link=tmp / "index")
    emulator.start()
    proc, base = start_server("contact-angle", ["--device", f"index=ferrovibe@{tmp / 'index'}"])
    try:
        get_json(base + "/api/placement/rig", "PUT", body=PLACEMENT)
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
            ctx = browser.new_context(viewport={"width": 1200, "height": 600}, bypass_csp=True)
            token = admin_token(base)
            ctx.add_init_script(f"try {{ localStorage.setItem('viestac.token', {token!r}); }} catch (e) {{}}")
            page = ctx.new_page()
            page.goto(base + "/?xr_emulator=quest3")
            page.wait_for_function("window.__viestac && window.__viestac.ready && window.__viestac.xrDevice", timeout=30_000)
            page.evaluate(SETUP)
            page.click("#xr button[data-mode=immersive-vr]")
            page.wait_for_function("window.__viestac.xr.active && window.__viestac.xr.joints.right", timeout=30_000)
            for _ in range(3):
                page.evaluate(MOVE, [on_dome(0.0, 0.3)])
                page.wait_for_timeout(100)

            # frame rate over `seconds`
            f0, t0 = page.evaluate("[window.__viestac.xr.stats.frames, performance.now()]")
            time.sleep(seconds)
            f1, t1 = page.evaluate("[window.__viestac.xr.stats.frames, performance.now()]")
            fps = (f1 - f0) * 1000.0 / (t1 - t0)

            offset_ns, clock_err_ms = _clock_offset_ns(page)
            jumps = []
            for k in range(touches):
                angle = ANGLES[k % len(ANGLES)]
                page.evaluate(MOVE, [on_dome(angle, 0.3)])
                _wait(lambda: not get_json(base + "/api/state")["contact"], 5, "contact to end")
                _wait(lambda: emulator.snapshot_edges() and emulator.snapshot_edges()[-1].magnitude == 0, 5, "the device flat")
                time.sleep(0.2)
                jumps.append(page.evaluate(PAGE_NOW))
                page.evaluate(MOVE, [on_dome(angle, -0.03)])  # one jump: the next frame's pose is inside
                _wait(lambda: page.evaluate("window.__viestac.xr.drawnHeld.length > 0"), 5, "the fingertip drawn held")
                _wait(lambda: any(e.magnitude > 0 for e in emulator.snapshot_edges()[-5:]), 5, "the device to tilt")
                time.sleep(0.1)
            log = page.evaluate("(() => { const l = window.__viestac.xr.log; return {samples: l.samples, draws: l.draws}; })()")
            edges = emulator.snapshot_edges()
            browser.close()
    finally:
        stop_server(proc)
        emulator.stop()

    inside = DOME_R + PROXY_R
    pose_to_drawn, pose_to_device, leads = [], [], []
    for k, jumped in enumerate(jumps):
        until = jumps[k + 1] if k + 1 < len(jumps) else math.inf
        sample = next((s for s in log["samples"] if jumped <= s[1] < until and math.hypot(*s[2]) < inside), None)
        if sample is None:
            continue
        t_pose = sample[1]
        drawn = next((d[0] for d in log["draws"] if d[1] and t_pose <= d[0] < until), None)
        pose_ns = t_pose * 1e6 + offset_ns
        edge = next((e for e in edges if e.magnitude > 0 and e.t_us * 1000 >= pose_ns), None)
        if drawn is not None:
            pose_to_drawn.append(drawn - t_pose)
        if edge is not None:
            pose_to_device.append((edge.t_us * 1000 - pose_ns) / 1e6)
            if drawn is not None:
                leads.append((drawn * 1e6 + offset_ns - edge.t_us * 1000) / 1e6)
    out = {"touches": touches, "xr_fps": round(fps, 1), "clock_map_err_ms": round(clock_err_ms, 3),
           "measured_drawn": len(pose_to_drawn), "measured_device": len(pose_to_device)}
    out.update(tail(sorted(pose_to_drawn), "pose_to_proxy_drawn_", "_ms", ci_for=()))
    out.update(tail(sorted(pose_to_device), "pose_to_device_", "_ms", ci_for=()))
    out.update(tail(sorted(leads), "tactile_leads_picture_", "_ms", ci_for=()))
    out["tactile_leads_within_15ms"] = bool(leads) and max(leads) <= 15.0
    return out
