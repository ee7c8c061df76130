"""`viestac bench xr`: the WebXR client in an emulated headset (docs/xr.md "Timing").

Headless Chromium (Debian's /usr/bin/chromium through Playwright, WebGL on SwiftShader) opens the
participant page with the Immersive Web Emulation Runtime (?xr_emulator=quest3: an emulated Meta
Quest 3, hand tracking, both eyes) against a server running contact-angle with a FerroVibe
emulator on the index. It enters immersive-vr and measures:

- **frame rate** of the session: XR frames drawn per second over `seconds` (the headset's own
  rate would be 72-120 Hz; here it is what SwiftShader manages on this machine's CPU);
- **hand pose → picture** (ms, and in XR frames: the pose read in frame n, drawn in frame
  n + k): the emulated fingertip jumps from 0.3 scene units above the dome to 0.03 inside it,
  `touches` times. From the XR frame that read the first joint pose inside (and sent it) to the
  end of the first XR frame that draws the fingertip on the surface (page clock), whichever put
  it there: the client's own prediction from its copy of the scene (`predicted`, in the pose's
  frame) or the server's proxy (`server`); the output counts both. **hand pose → server's proxy
  drawn** is the same to the first frame that draws the server's confirmed proxy;
- **hand pose → device command**: from that same frame to the FerroVibe emulator's first edge
  that tilts (CLOCK_MONOTONIC; the page's clock is mapped onto it by the tightest of 30
  evaluate round trips, ±half that round trip);
- **tactile leads picture**: the edge's time minus the picture's (positive: the device moved
  first); also against the server-confirmed picture. The picture's time is the end of the
  frame's rendering, so it includes one whole frame's render time (SwiftShader's ~50 ms here). The budget is 15 ms (haptic-before-visual asynchrony is noticed from about 15 ms,
  Di Luca & Mahnan 2019). A real headset adds its display's scan-out (~1 frame) to the picture.
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

from server.launcher import get_json, start_server, stop_server
from server.bench.quantiles import tail

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless=new", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run"]
PLACEMENT = {"table_height_m": 1.2, "origin_m": [0.0, -0.5], "yaw_deg": 0.0, "scale_m_per_unit": 0.1}
DOME_R, PROXY_R = 0.6, 0.06  # scenarios/contact_angle.py
ANGLES = (-60.0, -30.0, 0.0, 30.0, 60.0)
VIEWPORT = {"width": 800, "height": 400}  # both eyes side by side; SwiftShader's cost grows with it

SETUP = """() => { const d = window.__viestac.xrDevice; const a = -40 * Math.PI / 360;
    d.position.set(0, 1.45, -0.15); d.quaternion.set(Math.sin(a), 0, 0, Math.cos(a)); d.hands.left.position.set(-0.45, 0.9, 0.1); }"""
MOVE = """([scene]) => { const v = window.__viestac; const d = v.xrDevice, xr = v.xr;
    const tip = xr.joints.right['index-finger-tip']; const h = d.hands.right.position;
    const target = xr.toXr(scene);
    d.hands.right.position.set(h.x + target[0] - tip[0], h.y + target[1] - tip[1], h.z + target[2] - tip[2]); }"""
PAGE_NOW = "performance.now()"


def on_dome(angle_deg: float, out: float) -> list[float]:
    r = DOME_R + PROXY_R + out
    a = math.radians(angle_deg)
    return [0.0, r * math.sin(a), r * math.cos(a)]


def _clock_offset_ns(page, rounds: int = 20) -> float:
    """CLOCK_MONOTONIC ns − page ms (performance.now()) × 1e6. The page's timeOrigin is the wall
    clock at its start and performance.now() runs on the monotonic clock since, so a page time
    is timeOrigin + now on CLOCK_REALTIME; this machine's REALTIME − MONOTONIC (read back to back,
    the tightest pair) maps it. No round trip through the page's busy main thread."""
    origin_ms = page.evaluate("performance.timeOrigin")
    best = None
    for _ in range(rounds):
        m0 = time.monotonic_ns()
        r = time.time_ns()
        m1 = time.monotonic_ns()
        if best is None or m1 - m0 < best[0]:
            best = (m1 - m0, r - (m0 + m1) / 2)
    return origin_ms * 1e6 - best[1]


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

    from server.launcher import admin_token

    tmp = Path(tempfile.mkdtemp(prefix="viestac-xr-bench-"))
    emulator = Emulator("ferrovibe", link=tmp / "index")
    emulator.start()
    proc, base = start_server("contact-angle", ["--device", f"index=ferrovibe@{tmp / 'index'}"])
    try:
        get_json(base + "/api/placement/rig", "PUT", body=PLACEMENT)
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
            ctx = browser.new_context(viewport=VIEWPORT, bypass_csp=True)
            token = admin_token(base)
            ctx.add_init_script(f"try {{ localStorage.setItem('viestac.token', {token!r}); }} catch (e) {{}}")
            page = ctx.new_page()
            page.goto(base + "/?xr_emulator=quest3&xr_ttl=400")
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

            offset_ns = _clock_offset_ns(page)
            jumps = []
            for k in range(touches):
                angle = ANGLES[k % len(ANGLES)]
                page.evaluate(MOVE, [on_dome(angle, 0.3)])
                _wait(lambda: not get_json(base + "/api/state")["contact"], 5, "contact to end")
                _wait(lambda: all(e.magnitude == 0 for e in emulator.snapshot_edges()[-1:]), 5, "the device flat")
                time.sleep(0.2)
                jumps.append(page.evaluate(PAGE_NOW))
                page.evaluate(MOVE, [on_dome(angle, -0.03)])  # one jump: the next frame's pose is inside
                _wait(lambda: page.evaluate("window.__viestac.xr.drawnHeld.length > 0 && "
                                            "window.__viestac.xr.drawnPredicted.length === 0"), 5, "the server's proxy drawn")
                _wait(lambda: any(e.magnitude > 0 for e in emulator.snapshot_edges()[-5:]), 5, "the device to tilt")
                time.sleep(0.1)
            log = page.evaluate("(() => { const l = window.__viestac.xr.log; return {samples: l.samples, draws: l.draws}; })()")
            edges = emulator.snapshot_edges()
            applied = get_json(base + "/api/trackers?limit=4096")
            browser.close()
    finally:
        stop_server(proc)
        emulator.stop()

    inside = DOME_R + PROXY_R
    pose_to_drawn, pose_to_device, leads, frames = [], [], [], []
    pose_to_server, server_frames, server_leads, how = [], [], [], {"predicted": 0, "server": 0}
    for k, jumped in enumerate(jumps):
        until = jumps[k + 1] if k + 1 < len(jumps) else math.inf
        sample = next((s for s in log["samples"] if jumped <= s[1] < until and math.hypot(*s[2]) < inside), None)
        if sample is None:
            continue
        t_pose = sample[1]
        draw = next((d for d in log["draws"] if d[1] and t_pose <= d[0] < until), None)
        drawn = draw[0] if draw else None
        if draw:
            frames.append(draw[2] - sample[3])
            how[draw[3]] += 1
        confirmed = next((d for d in log["draws"] if d[3] == "server" and t_pose <= d[0] < until), None)
        if confirmed:
            pose_to_server.append(confirmed[0] - t_pose)
            server_frames.append(confirmed[2] - sample[3])
        pose_ns = t_pose * 1e6 + offset_ns
        edge = next((e for e in edges if e.magnitude > 0 and e.t_us * 1000 >= pose_ns), None)
        if drawn is not None:
            pose_to_drawn.append(drawn - t_pose)
        if edge is not None:
            pose_to_device.append((edge.t_us * 1000 - pose_ns) / 1e6)
            if drawn is not None:
                leads.append((drawn * 1e6 + offset_ns - edge.t_us * 1000) / 1e6)
            if confirmed:
                server_leads.append((confirmed[0] * 1e6 + offset_ns - edge.t_us * 1000) / 1e6)
    # check of the clock map: page send → hub read of the same samples (≥ 0, small on one machine)
    cols = applied["columns"]
    by_seq = {row[cols.index("seq")]: row[cols.index("hub_recv_ns")] for row in applied["rows"]}
    transit = sorted((by_seq[s[0]] - (s[1] * 1e6 + offset_ns)) / 1e6 for s in log["samples"] if s[0] in by_seq)
    out = {"touches": touches, "xr_fps": round(fps, 1), "viewport": f"{VIEWPORT['width']}x{VIEWPORT['height']}",
           "measured_drawn": len(pose_to_drawn), "measured_device": len(pose_to_device)}
    out["picture_predicted"], out["picture_server"] = how["predicted"], how["server"]
    frame_points = (("p50", 0.5), ("max", 1.0))
    out.update(tail(sorted(pose_to_drawn), "pose_to_picture_", "_ms", ci_for=()))
    out.update(tail(sorted(frames), "pose_to_picture_", "_frames", points=frame_points, ci_for=()))
    out.update(tail(sorted(pose_to_server), "pose_to_server_proxy_drawn_", "_ms", ci_for=()))
    out.update(tail(sorted(server_frames), "pose_to_server_proxy_drawn_", "_frames", points=frame_points, ci_for=()))
    out.update(tail(sorted(pose_to_device), "pose_to_device_", "_ms", ci_for=()))
    out.update(tail(sorted(leads), "tactile_leads_picture_", "_ms", ci_for=()))
    out.update(tail(sorted(server_leads), "tactile_leads_server_picture_", "_ms", ci_for=()))
    out.update(tail(transit, "page_send_to_hub_", "_ms", points=(("min", 0.0), ("p50", 0.5)), ci_for=()))
    out["tactile_leads_within_15ms"] = bool(leads) and max(leads) <= 15.0
    return out
