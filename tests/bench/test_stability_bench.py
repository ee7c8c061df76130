"""`viestac bench stability`: the quick bench end to end (once per module), and its building blocks
against closed forms and hand-made cases."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from scenarios.registry import SCENARIOS
from server.bench.contact_methods import MethodStep
from server.bench.force_device import ForceDevice, measure_oscillation, simulate_wall
from server.bench.stability import (KIND_DELAYED, KIND_LOST, KIND_POP, KIND_TUNNEL, chatter_rate, contact_signal,
                                    first_failure, pass_heights, resting_point, run_stability_bench)
from server.core.haptics.contact_gate import ContactGate

CHARTS = ("popthrough", "stiffness", "chatter")


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    out = tmp_path_factory.mktemp("stability")
    summary = run_stability_bench(out, quick=True)
    return out, summary, json.loads((out / "stability.json").read_text())


def _numbers(node):
    """Every number in a JSON tree."""
    if isinstance(node, dict):
        for v in node.values():
            yield from _numbers(v)
    elif isinstance(node, list):
        for v in node:
            yield from _numbers(v)
    elif isinstance(node, (int, float)) and not isinstance(node, bool):
        yield node


# -- the quick bench ---------------------------------------------------------------------------

def test_summary_is_flat_json_with_positive_wall_times(bench):
    _, summary, report = bench
    assert report["summary"] == summary
    json.dumps(summary)
    assert all(not isinstance(v, (dict, list)) for v in summary.values())
    for sweep in CHARTS:
        assert summary[f"wall_s_{sweep}"] > 0
        assert report[sweep]["wall_s"] > 0
    assert summary["stiffness_passivity_bound_at_1000hz_n_per_m"] == pytest.approx(2000.0)
    assert 0 < summary["stiffness_largest_stable_at_1000hz_n_per_m"] < 4000


def test_report_numbers_are_finite(bench):
    _, _, report = bench
    assert all(math.isfinite(x) for x in _numbers(report))
    assert report["popthrough"]["parameters"]["proxy_radius_m"] == 0.0
    assert {"popthrough", "stiffness", "chatter", "defaults", "machine"} <= set(report)
    for cell in report["stiffness"]["cells"]:
        assert cell["late_p2p_m"] >= 0 and cell["relative_p2p"] >= 0
    for cell in report["chatter"]["cells"]:
        assert cell["chatter_per_s"] >= 0


def test_charts_are_non_empty_png_and_svg(bench):
    out, summary, _ = bench
    for name in CHARTS:
        png, svg = out / f"{name}.png", out / f"{name}.svg"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
        assert "<svg" in svg.read_text()[:1000]
        assert str(png) in summary["out_charts"]


def test_analytic_never_pops_through_and_a_baseline_does(bench):
    _, summary, report = bench
    pop = report["popthrough"]
    analytic = [c for c in pop["cells"] if c["family"] == "analytic"]
    assert analytic and all(c["failures"] == 0 for c in analytic)
    assert all(c["proxy_depth_max_m"] < 1e-9 for c in analytic)  # the proxy stays on the top face
    assert len(analytic) == len(pop["parameters"]["speeds_m_s"]) * len(pop["parameters"]["thicknesses_m"])
    assert summary["popthrough_analytic_failing_runs"] == 0
    penalty = next(m for m in pop["methods"] if m["family"] == "penalty")
    assert penalty["failing_cells"] > 0
    # a thick plate is pushed out of the far side, a thin one crossed fast is tunnelled
    kinds = {(c["thickness_m"], c["speed_m_s"]): c["kind"] for c in pop["cells"] if c["family"] == "penalty"}
    assert kinds[(max(pop["parameters"]["thicknesses_m"]), min(pop["parameters"]["speeds_m_s"]))] == KIND_POP
    assert kinds[(min(pop["parameters"]["thicknesses_m"]), max(pop["parameters"]["speeds_m_s"]))] == KIND_TUNNEL


def test_defaults_sit_in_the_stable_region(bench):
    _, summary, report = bench
    assert summary["defaults_stable"] is True
    assert all(v["stable"] for v in report["defaults"].values())
    assert report["defaults"]["gate"]["chatter_per_s"] <= report["chatter"]["parameters"]["stable_threshold_per_s"]
    assert report["defaults"]["stiffness"]["margin"] > 1


def test_bad_out_path_is_a_clear_error(tmp_path):
    target = tmp_path / "file"
    target.write_text("x")
    with pytest.raises(ValueError, match="not a directory"):
        run_stability_bench(target, quick=True)


# -- pop-through classifier ------------------------------------------------------------------

def _ticks(rows):
    """(z, MethodStep) from (z, force z, contact) rows."""
    return [(z, MethodStep((0.0, 0.0, 0.0), (0.0, 0.0, fz), contact)) for z, fz, contact in rows]


@pytest.mark.parametrize("rows, kind", [
    ([(0.01, 0.0, False), (-0.005, 5.0, True), (-0.015, 15.0, True)], None),
    ([(0.01, 0.0, False), (-0.002, 2.0, True), (-0.008, -2.0, True)], KIND_POP),
    ([(0.01, 0.0, False), (-0.02, 0.0, False)], KIND_TUNNEL),
    ([(0.01, 0.0, False), (-0.005, 0.0, False), (-0.012, 2.0, True)], KIND_TUNNEL),  # caught below the bottom
    ([(0.01, 0.0, False), (-0.005, 0.0, False), (-0.008, 1.0, True)], KIND_DELAYED),
    ([(0.01, 0.0, False), (-0.002, 2.0, True), (-0.02, 0.0, False)], KIND_LOST),
])
def test_first_failure_classifies_hand_made_passes(rows, kind):
    assert first_failure(_ticks(rows), top=0.0, bottom=-0.01) == kind


def test_first_failure_stops_at_the_failure():
    rows = iter(_ticks([(0.01, 0.0, False), (-0.002, -1.0, True), (-0.004, 1.0, True)]))
    assert first_failure(rows, top=0.0, bottom=-0.01) == KIND_POP
    assert len(list(rows)) == 1  # the tick after the failure was never asked for


def test_pass_starts_above_and_ends_below_by_more_than_a_step():
    step = 0.003
    zs = pass_heights(0.0, -0.01, step, 0.4)
    assert zs[0] > step and zs[-1] < -0.01 - step and zs[-2] >= -0.01 - step
    assert np.allclose(np.diff(zs), -step)


# -- force device --------------------------------------------------------------------------

def test_device_free_motion_matches_the_ode():
    device = ForceDevice(mass_kg=0.05, damping_n_s_per_m=1.0)
    x0, v0, force = 0.3, 0.2, -1.0
    ts = np.linspace(0.0, 0.4, 41)
    ode = solve_ivp(lambda t, s: [s[1], (force - device.damping_n_s_per_m * s[1]) / device.mass_kg],
                    (0.0, 0.4), [x0, v0], t_eval=ts, rtol=1e-11, atol=1e-13, method="DOP853")
    assert np.allclose([device.free_position(x0, v0, force, t) for t in ts], ode.y[0], atol=1e-10)
    x, v = x0, v0
    for k in range(1, len(ts)):  # exact steps compose: no integration error accumulates
        x, v = device.advance(x, v, force, ts[k] - ts[k - 1])
        assert x == pytest.approx(ode.y[0][k], abs=1e-10) and v == pytest.approx(ode.y[1][k], abs=1e-9)


def test_device_far_from_the_wall_moves_freely():
    device = ForceDevice()
    trace = simulate_wall(device, 1000.0, 1000.0, push_n=1.0, duration_s=0.2, x0=1.0, v0=0.0)
    assert not any(trace.contacts)
    expect = [device.free_position(1.0, 0.0, -1.0, k / 1000.0) for k in range(len(trace.positions))]
    assert np.allclose(trace.positions, expect, atol=1e-12)


def test_soft_wall_settles_to_the_static_penetration():
    device = ForceDevice()
    k = 0.1 * device.passivity_bound(1000.0)
    trace = simulate_wall(device, k, 1000.0, push_n=1.0, duration_s=3.0)
    assert trace.positions[-1] == pytest.approx(-1.0 / k, rel=1e-6)
    assert trace.forces[-1] == pytest.approx(1.0, rel=1e-6)
    assert not measure_oscillation(trace, 1.0 / k, 0.5).oscillating


def test_stiff_wall_far_above_the_bound_oscillates():
    device = ForceDevice()
    k = 10 * device.passivity_bound(1000.0)
    trace = simulate_wall(device, k, 1000.0, push_n=1.0, duration_s=3.0)
    result = measure_oscillation(trace, 1.0 / k, 0.5)
    assert result.oscillating and result.bounces > 0 and result.relative_p2p > 1


def test_device_rejects_bad_parameters():
    with pytest.raises(ValueError, match="mass_kg"):
        ForceDevice(mass_kg=0.0)
    with pytest.raises(ValueError, match="rate_hz"):
        simulate_wall(ForceDevice(), 1000.0, -1.0)


# -- chatter -------------------------------------------------------------------------------

def test_hysteresis_gate_removes_the_raw_chatter_on_the_same_noise():
    scene = SCENARIOS["contact-angle-v1"].factory().build_scene()
    bodies, radius = list(scene.bodies()), scene.proxy_radius
    mean = resting_point(bodies, radius)
    assert mean == pytest.approx((0.0, 0.0, 0.66))
    noise = 0.0005 * np.random.default_rng(1).standard_normal((241, 3))
    signal = contact_signal(bodies, radius, mean, noise, 1000, 120, 2000)
    raw = chatter_rate(signal, ContactGate(0.0, 0.0, 0.0), 1000)
    gated = chatter_rate(signal, ContactGate(0.002, 0.03, 0.03), 1000)
    assert raw > 20  # resting on the surface, the raw flag flips with about every other frame
    assert gated == 0.0
    quiet = contact_signal(bodies, radius, mean, 0.0 * noise, 1000, 120, 2000)
    assert chatter_rate(quiet, ContactGate(0.0, 0.0, 0.0), 1000) == 0.0
