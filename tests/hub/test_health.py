"""Health (server/hub/health.py) on made-up times: each reason appears when its condition holds,
names what to do, and clears when the condition ends; `starting` before the first tick."""

import pytest

from devices.capability import showing
from devices.profiles import profile_by_model
from server.hub.health import CODES, Health

RIG = {"fingertac": profile_by_model("fingertac"), "ferrovibe": profile_by_model("ferrovibe")}
BOTH_CONNECTED = {"fingertac": "connected", "ferrovibe": "connected"}


def ticking(t0: float = 0.0, **kw) -> Health:
    """A server whose loop and device host run and whose loop has ticked at t0."""
    health = Health(**kw)
    health.loop_started(t0 - 1.0)
    health.device_host_started(t0 - 1.0)
    health.devices(BOTH_CONNECTED, t0 - 0.5)
    health.needs("contact-angle", showing(("macro_roughness",), RIG))
    health.state(t0)
    return health


def codes(health: Health, now: float) -> list[str]:
    return [r["code"] for r in health.evaluate(now).reasons]


def test_starting_until_the_first_state_then_ok():
    health = Health()
    health.loop_started(0.0)
    assert health.evaluate(0.5).status == "starting"
    health.state(0.6)
    report = health.evaluate(0.61)
    assert report.status == "ok" and report.reasons == ()


def test_a_dead_loop_is_loop_down_until_it_runs_again():
    health = ticking()
    health.loop_exited(0.01, -9)
    report = health.evaluate(0.02)
    assert report.status == "degraded" and report.codes == {"loop_down"}
    assert "killed by signal 9" in report.reasons[0]["message"] and report.reasons[0]["since_s"] == 0.01
    health.loop_started(0.03)
    assert codes(health, 0.035) == ["loop_down"], "restarted, not ticking yet: still down, no gap of 'ok'"
    assert codes(health, 0.2) == ["loop_down"]
    health.state(0.25)
    assert health.evaluate(0.26).status == "ok"


def test_a_loop_that_stops_ticking_is_stalled_after_50_ms():
    health = ticking()
    health.state(1.0)
    assert health.evaluate(1.04).status == "ok"
    report = health.evaluate(1.07)
    assert report.status == "degraded" and report.codes == {"loop_stalled"}
    assert report.reasons[0]["since_s"] == pytest.approx(0.07)
    health.state(1.5)
    assert health.evaluate(1.51).status == "ok"


def test_a_fault_record_is_tick_failures_until_recovered_or_quiet():
    health = ticking(0.1)
    health.fault(0.1, failures=1, error="OverflowError: math range error")
    report = health.evaluate(0.11)
    assert report.codes == {"tick_failures"} and "OverflowError" in report.reasons[0]["message"]
    health.state(0.12, failures=1)
    health.recovered(0.13, failures=1)
    health.state(0.14, failures=1)
    assert health.evaluate(0.15).status == "ok", "recovered clears it at once"
    health.fault(0.2, failures=2)
    for t in (0.25, 0.3, 0.35, 0.4, 0.45, 0.5, 0.55, 0.6, 0.65, 0.7, 0.75):
        health.state(t, failures=2)
    assert codes(health, 0.69) == ["tick_failures"]
    assert codes(health, 0.75) == [], "no new failure for 0.5 s: clears without a recovered record"


def test_a_rising_failure_count_in_state_records_counts_as_a_fault():
    health = ticking()
    health.state(0.01, failures=0)
    health.state(0.02, failures=5)
    assert codes(health, 0.03) == ["tick_failures"]
    health.loop_exited(0.04)
    health.loop_started(0.05)
    health.state(0.6, failures=0)  # a new loop counts from 0: not a fault
    assert codes(health, 0.6) == []


def test_the_needed_device_disconnected_is_named_with_what_to_do():
    health = ticking()
    health.devices({"ferrovibe": "disconnected"}, 0.1)
    health.state(0.12)
    report = health.evaluate(0.13)
    assert report.status == "degraded" and report.codes == {"device_missing"}
    message = report.reasons[0]["message"]
    assert "'ferrovibe' is disconnected" in message and "cable" in message and "'contact-angle'" in message
    assert "tilt" in message
    assert report.reasons[0]["since_s"] == pytest.approx(0.03)
    health.devices({"ferrovibe": "connected"}, 0.2)
    health.state(0.2)
    assert health.evaluate(0.21).status == "ok"


def test_a_device_the_scenario_does_not_need_is_a_note_not_a_reason():
    health = ticking()
    health.devices({"fingertac": "disconnected"}, 0.1)
    health.state(0.1)
    report = health.evaluate(0.11)
    assert report.status == "ok" and report.notes[0]["code"] == "device_disconnected"
    assert "'fingertac'" in report.notes[0]["message"]
    # texture: both devices show fine roughness; one of them gone is still served by the other
    health.needs("texture", showing(("fine_roughness",), RIG))
    health.devices({"fingertac": "connected", "ferrovibe": "disconnected"}, 0.12)
    report = health.evaluate(0.12)
    assert report.status == "ok" and [n["message"][:18] for n in report.notes] == ["device 'ferrovibe'"]
    health.devices({"fingertac": "unresponsive"}, 0.13)
    report = health.evaluate(0.13)
    assert report.codes == {"device_missing"} and len(report.reasons) == 2, "both devices named"


def test_the_device_host_down_then_restarted():
    health = ticking(0.1)
    health.device_host_exited(0.1, -9)
    report = health.evaluate(0.11)
    assert {"device_host_down", "device_missing"} == report.codes, "its devices are driven by nobody"
    health.device_host_started(0.6)
    health.state(0.6)
    assert codes(health, 0.61) == ["device_missing", "device_host_restarted"]
    health.devices(BOTH_CONNECTED, 0.9)
    health.state(2.6)
    assert codes(health, 2.6) == ["device_host_restarted"]
    health.state(2.62)
    assert health.evaluate(2.62).status == "ok", "2 s after the restart"


def test_overruns_over_the_threshold_in_the_window():
    health = ticking(overrun_threshold=10)
    health.state(1.0, overruns=6)
    health.state(2.0, overruns=4)
    assert health.evaluate(2.0).status == "ok", "10 is not over 10"
    health.state(3.0, overruns=1)
    report = health.evaluate(3.0)
    assert report.codes == {"overruns"} and "11 times" in report.reasons[0]["message"]
    health.state(11.0)
    assert health.evaluate(11.0).status == "ok", "the first 6 left the 10 s window"


def test_every_code_is_reachable_and_declared():
    seen = set()
    health = ticking()
    health.fault(0.01, 1)
    health.devices({"ferrovibe": "disconnected"}, 0.01)
    health.state(0.01, overruns=50)
    health.device_host_exited(0.01)
    seen |= health.evaluate(0.02).codes
    health.device_host_started(0.03)
    seen |= health.evaluate(0.1).codes  # loop stalled, host restarted
    health.loop_exited(0.11)
    seen |= health.evaluate(0.12).codes
    assert seen == set(CODES)


def test_a_new_loops_start_up_ticks_are_not_counted_as_overruns():
    health = ticking(overrun_threshold=10)
    health.loop_exited(5.0, -9)
    health.loop_started(5.1)
    health.state(5.3, overruns=40)  # the new process's first ticks: late, and already reported as loop_down
    health.state(5.5)
    assert "overruns" not in health.evaluate(5.5).codes
    health.state(6.2, overruns=11)  # past the grace: counted
    assert "overruns" in health.evaluate(6.2).codes
