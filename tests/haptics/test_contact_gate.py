"""Contact gate: Leap-like jitter at a surface must not chatter; real presses still switch."""

from __future__ import annotations

import random

import pytest

from server.core.haptics.primitives import Body, Hemisphere, Plane

from .implementations import GATES, GOD_OBJECTS

ContactGate = GodObject = None  # the implementations under test, set per test by the fixture below


@pytest.fixture(autouse=True, params=list(zip(GATES, GOD_OBJECTS)), ids=["reference", "compiled"])
def _implementation(request, monkeypatch):
    """Every test here runs against the Python reference and against the compiled core."""
    gate, god = request.param
    if any(m.name == "skipif" and m.args[0] for p in (gate, god) for m in p.marks):
        pytest.skip(gate.marks[0].kwargs["reason"])
    monkeypatch.setitem(globals(), "ContactGate", gate.values[0])
    monkeypatch.setitem(globals(), "GodObject", god.values[0])

RATE_HZ = 120.0  # Leap Motion frame rate
SIGMA_M = 0.0005  # static jitter sigma (Guna et al. 2014: < 0.5 mm)


def _run(gate, samples, bodies, radius=0.0):
    """Feed HIP samples at 120 Hz through a god-object and the gate; returns (raw toggles,
    gate transition times, final state)."""
    go = GodObject(radius)
    raw_prev, raw_toggles, transitions = False, 0, []
    on = gate.on
    for n, hip in enumerate(samples):
        t = n / RATE_HZ
        step = go.step(bodies, hip)
        touching = bool(step.contacts)
        raw_toggles += touching != raw_prev
        raw_prev = touching
        state = gate.update(t, touching, step.separation)
        assert state == gate.on
        if state != on:
            transitions.append(t)
            on = state
    return raw_toggles, transitions, on


@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("where", ["ground", "dome"])
def test_jitter_at_a_surface_does_not_chatter(seed, where):
    rng = random.Random(seed)
    bodies = [Body("dome", Hemisphere(0.6)), Body("ground", Plane((3.0, 3.0)))]
    rest = (0.0, 1.0, 0.0) if where == "ground" else (0.0, 0.0, 0.6)
    samples = [tuple(c + rng.gauss(0.0, SIGMA_M) for c in rest) for _ in range(int(10 * RATE_HZ))]
    gate = ContactGate()
    raw_toggles, transitions, on = _run(gate, samples, bodies)
    assert raw_toggles > 100  # the raw contact flag chatters at the tracker rate
    assert 1 <= len(transitions) <= 3 and on  # the gate switches on and stays (nearly) on
    gaps = [b - a for a, b in zip(transitions, transitions[1:])]
    assert all(g >= min(gate.min_on_s, gate.min_off_s) - 1e-12 for g in gaps)


def test_real_press_and_release_still_switch():
    rng = random.Random(4)
    bodies = [Body("ground", Plane((3.0, 3.0)))]
    samples = []
    for _cycle in range(4):  # 0.5 s pressed 3 mm in, 0.5 s lifted 20 mm out, with jitter
        for z in [-0.003] * 60 + [0.02] * 60:
            samples.append((0.0, 0.0, z + rng.gauss(0.0, SIGMA_M)))
    gate = ContactGate()
    _, transitions, on = _run(gate, samples, bodies)
    assert len(transitions) == 8 and not on
    for k, t in enumerate(transitions):  # on within a frame of the press, off of the lift
        assert abs(t - k * 0.5) <= 1.0 / RATE_HZ + 1e-9


def test_dwell_times_and_band_are_enforced():
    gate = ContactGate(band=0.002, min_on_s=0.03, min_off_s=0.05)
    assert gate.update(0.0, True, -0.001)  # first contact: on at once
    assert gate.update(0.01, False, 0.01)  # far out but only 10 ms on: stays on
    assert not gate.update(0.03, False, 0.01)  # 30 ms: off
    assert not gate.update(0.07, True, -0.001)  # 40 ms off < min_off_s: stays off
    assert gate.update(0.08, True, -0.001)  # 50 ms: on
    assert gate.update(0.5, False, 0.0019)  # out of contact but inside the band: stays on
    assert not gate.update(0.6, False, 0.002)  # leaves the band: off
    gate.reset()
    assert not gate.on and gate.update(0.601, True, 0.0)  # reset clears the dwell
    for bad in [(-1, 0.03, 0.03), (0.002, -0.1, 0.03), (0.002, 0.03, float("nan"))]:
        with pytest.raises(ValueError):
            ContactGate(*bad)
