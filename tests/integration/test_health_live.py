"""Health against a real server (hub, 1 kHz loop, device host, the simulated rig's emulators):
each fault makes /api/health `degraded` with its reason before the fault is repaired, and `ok`
again afterwards; a trial that needs the killed device is refused (409) unless forced.

How fast health notices is printed (pytest -s), not asserted: timing goals live in the benches.
"""

from __future__ import annotations

import json
import os
import signal
import time
import urllib.error

import pytest

from tests.live_server import get_json
from tests.integration.test_experiment_live import Api, new_session

POLL_S = 0.005


@pytest.fixture(scope="module")
def base(own_server):
    return own_server.http_url


def health(base: str) -> dict:
    return get_json(base + "/api/health")


def wait_health(base: str, done, timeout_s: float, what: str) -> tuple[float, dict]:
    """Poll /api/health every 5 ms until `done(health)`; seconds it took and that health."""
    start = time.monotonic()
    while True:
        h = health(base)
        if done(h):
            return time.monotonic() - start, h
        if time.monotonic() - start > timeout_s:
            raise AssertionError(f"{what} not seen within {timeout_s} s; health is {json.dumps(h)[:800]}")
        time.sleep(POLL_S)


def degraded_by(code: str):
    return lambda h: h["status"] == "degraded" and code in {r["code"] for r in h["reasons"]}


def is_ok(h: dict) -> bool:
    return h["status"] == "ok" and h["reasons"] == []


def post(base: str, path: str, body: dict) -> tuple[int, dict]:
    try:
        return 200, get_json(base + path, "POST", body=body)
    except urllib.error.HTTPError as exc:
        return exc.code, json.loads(exc.read())


def test_a_stalled_loop_is_degraded_and_ok_again_when_it_ticks(base):
    wait_health(base, is_ok, 10, "ok")
    pid = health(base)["loop"]["pid"]
    os.kill(pid, signal.SIGSTOP)
    try:
        took, h = wait_health(base, degraded_by("loop_stalled"), 5, "loop_stalled")
    finally:
        os.kill(pid, signal.SIGCONT)
    print(f"\nloop SIGSTOP -> degraded (loop_stalled) seen after {took * 1000:.0f} ms")
    assert "not ticked" in next(r for r in h["reasons"] if r["code"] == "loop_stalled")["message"]
    wait_health(base, is_ok, 5, "ok after SIGCONT")


def test_a_killed_loop_is_degraded_until_the_restarted_loop_ticks(base):
    wait_health(base, is_ok, 10, "ok")
    pid = health(base)["loop"]["pid"]
    os.kill(pid, signal.SIGKILL)
    took, h = wait_health(base, lambda h: h["status"] == "degraded", 5, "degraded")
    print(f"\nloop kill -9 -> degraded ({[r['code'] for r in h['reasons']]}) seen after {took * 1000:.0f} ms")
    took_ok, h = wait_health(base, lambda h: is_ok(h) and h["loop"]["pid"] != pid, 15, "ok with a new loop")
    print(f"loop kill -9 -> ok again after {took + took_ok:.2f} s")


def test_a_killed_device_host_is_degraded_until_it_is_back(base):
    wait_health(base, is_ok, 10, "ok")
    pid = get_json(base + "/api/devices")["host"]["pid"]
    os.kill(pid, signal.SIGKILL)
    # the first death is restarted at once, so 'down' may last less than one poll: either code
    took, h = wait_health(base, lambda h: degraded_by("device_host_down")(h) or degraded_by("device_host_restarted")(h),
                          5, "device_host_down or device_host_restarted")
    print(f"\ndevice host kill -9 -> degraded ({[r['code'] for r in h['reasons']]}) seen after {took * 1000:.0f} ms")
    took_ok, _ = wait_health(base, is_ok, 15, "ok after the device host restarted")
    print(f"device host kill -9 -> ok again after {took + took_ok:.2f} s")


def test_a_killed_device_emulator_is_device_missing_and_its_trial_is_refused_unless_forced(base):
    wait_health(base, is_ok, 10, "ok")
    assert post(base, "/api/trial", {"phase": "main", "params": {"angle_deg": 10}})[0] == 200
    get_json(base + "/api/trial", "DELETE")
    emulators = get_json(base + "/api/devices")["simulated_rig"]["emulators"]
    os.kill(emulators["ferrovibe"]["pid"], signal.SIGKILL)
    took, h = wait_health(base, degraded_by("device_missing"), 5, "device_missing")
    print(f"\nferrovibe emulator kill -9 -> degraded (device_missing) seen after {took * 1000:.0f} ms")
    reason = next(r for r in h["reasons"] if r["code"] == "device_missing")
    assert "'ferrovibe'" in reason["message"] and "contact-angle" in reason["message"]

    scenario = get_json(base + "/api/scenario")["capability"]
    ferro = next(d for d in scenario["devices"] if d["name"] == "ferrovibe")
    assert ferro["usable"] is False and ferro["status"] != "connected" and "ferrovibe" not in scenario["usable"]

    code, body = post(base, "/api/trial", {"phase": "main", "params": {"angle_deg": 10}})
    assert code == 409 and "'ferrovibe'" in body["detail"], body
    code, body = post(base, "/api/trial", {"phase": "main", "params": {"angle_deg": 10}, "force": True})
    assert code == 200 and body["trial"]["phase"] == "main"
    get_json(base + "/api/trial", "DELETE")

    # the experiment engine refuses the study's next trial too, before anything is recorded
    api = Api(base)
    sid = new_session(api, "P07")["id"]
    status, err = api.call("POST", f"/api/sessions/{sid}/trials/0/start")
    assert status == 409 and "'ferrovibe'" in err["detail"], err
    assert api.ok("GET", f"/api/sessions/{sid}")["trials"][0]["status"] == "pending"
    started = api.ok("POST", f"/api/sessions/{sid}/trials/0/start?force=true")
    assert started["status"] == "running"
