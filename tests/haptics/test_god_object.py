"""Acceptance tests for the god-object (server.core.haptics.god_object).

Every test runs against both implementations (the Python reference and the compiled core).
Ground truth is the analytic signed distance of each body (tested on its own in
test_primitives.py); "free segment" is decided independently of Body.cast by minimising the
convex function sd(a + t(b - a)) with a golden-section search.
"""

from __future__ import annotations

import math
import random
import time

import pytest

from server.core.haptics import vec
from server.core.haptics.primitives import (Body, Box, Cone, Cylinder, Hemisphere, Plane, Pose,
                                       Sphere)

from .implementations import GOD_OBJECTS

GodObject = None  # the implementation under test, set per test by the fixture below


@pytest.fixture(autouse=True, params=GOD_OBJECTS)
def _implementation(request, monkeypatch):
    """Every test here runs against the Python reference and against the compiled core."""
    monkeypatch.setitem(globals(), "GodObject", request.param)

Q = (0.9238795325112867, 0.2126311, -0.1876923, 0.25)  # an arbitrary rotation (normalised)

SHAPES = {
    "sphere": (Sphere(0.5), 0.5),
    "box": (Box((0.6, 0.4, 0.3)), 0.45),
    "cylinder": (Cylinder(0.3, 0.6), 0.55),
    "cone": (Cone(0.4, 0.7), 0.6),
    "plane": (Plane((1.5, 1.0)), 0.9),
    "hemisphere": (Hemisphere(0.5), 0.5),
}


def bodies_for(name):
    """The same shape with an identity pose and with a rotated, shifted pose."""
    shape, _ = SHAPES[name]
    return [Body(name, shape), Body(name, shape, Pose((0.1, -0.2, 0.05), Q))]


def centre_of(body):
    local = {"cylinder": (0, 0, 0.3), "cone": (0, 0, 0.25), "plane": (0, 0, -0.2),
             "hemisphere": (0, 0, 0.2)}.get(body.id, (0, 0, 0))
    return body.pose.to_world(local)


def phi(body, p, r):
    return body.signed_distance(p) - r


def segment_min_phi(body, a, b, r):
    """min over t in [0,1] of the convex function sd(a + t(b - a)) - r (golden section)."""
    lo, hi = 0.0, 1.0
    g = (math.sqrt(5) - 1) / 2
    f = lambda t: phi(body, vec.lerp(a, b, t), r)  # noqa: E731
    for _ in range(80):
        m1, m2 = hi - g * (hi - lo), lo + g * (hi - lo)
        if f(m1) < f(m2):
            hi = m2
        else:
            lo = m1
    return min(f(0.0), f(1.0), f((lo + hi) / 2))


def random_inside(rng, body, r, extent):
    c = centre_of(body)
    while True:
        p = tuple(c[i] + rng.uniform(-extent, extent) for i in range(3))
        if phi(body, p, r) < -1e-6:
            return p


def random_outside(rng, body, r, extent):
    c = centre_of(body)
    while True:
        u = vec.normalize(tuple(rng.gauss(0, 1) for _ in range(3)))
        p = vec.add(c, vec.scale(u, extent * rng.uniform(1.1, 2.0) + r))
        if phi(body, p, r) > 1e-3:
            return p


def check_step(body, go, step, hip, prev_proxy, r):
    """The invariants of every tick; returns True if the HIP was inside."""
    proxy = step.proxy
    k = body.stiffness_n_per_m
    assert proxy == go.proxy
    fp = phi(body, proxy, r)
    assert fp >= -1e-9, "proxy inside the body"
    fh = phi(body, hip, r)
    if fh < 0.0:
        assert abs(fp) <= 1e-9, "HIP inside but the proxy is off the surface"
    if proxy != hip:
        assert abs(fp) <= 1e-9 and step.contacts
        assert step.force == (k * (proxy[0] - hip[0]), k * (proxy[1] - hip[1]),
                              k * (proxy[2] - hip[2]))
    else:
        assert step.force == (0.0, 0.0, 0.0) and step.contacts == ()
    assert step.separation == fh
    if fh > 1e-9 and proxy != hip:
        # outside: the proxy must be the HIP unless the straight path from the last proxy
        # really crosses the body
        assert segment_min_phi(body, prev_proxy, hip, r) <= 1e-9, "proxy held in free space"
    return fh < 0.0


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_random_paths_never_penetrate(name):
    """10^4 random HIP paths entering each primitive (point and radius proxy, identity and
    rotated pose, 8 ticks each, some crossing the whole body in one tick)."""
    rng = random.Random(1 + sorted(SHAPES).index(name))
    _, extent = SHAPES[name]
    entered = 0
    for n in range(10_000):
        body = bodies_for(name)[n % 2]
        r = 0.0 if n % 4 < 2 else 0.03
        go = GodObject(r)
        hip = random_outside(rng, body, r, extent)
        target = random_inside(rng, body, r, extent)
        k1 = rng.randint(1, 4)
        path = [vec.lerp(hip, target, (i + 1) / k1) for i in range(k1)]
        while len(path) < 8:
            path.append(vec.add(path[-1], tuple(rng.uniform(-0.25, 0.25) * extent
                                                for _ in range(3))))
        step = go.step([body], hip)
        assert step.proxy == hip and step.contacts == ()
        inside_seen = False
        for h in path:
            prev = go.proxy
            step = go.step([body], h)
            inside = check_step(body, go, step, h, prev, r)
            if inside and not inside_seen:
                assert step.contacts, "no force on the first tick of contact"
                inside_seen = True
        entered += inside_seen
    assert entered == 10_000  # every path entered the body at least once


def tangential(force, normal):
    fn = vec.dot(force, normal)
    return vec.norm(vec.sub(force, vec.scale(normal, fn)))


@pytest.mark.parametrize("name", sorted(SHAPES))
@pytest.mark.parametrize("r", [0.0, 0.03])
def test_proxy_settles_on_a_local_minimum(name, r):
    rng = random.Random(5)
    _, extent = SHAPES[name]
    for n in range(60):
        body = bodies_for(name)[n % 2]
        go = GodObject(r)
        start = random_outside(rng, body, r, extent)
        while True:
            target = random_inside(rng, body, r, extent)
            local = body.pose.to_local(target)
            if math.hypot(local[0], local[1]) > 0.05 or name in ("box", "plane"):
                break  # keep off the axis, where curvature radius -> 0 and settling is slow
        go.step([body], start)
        go.step([body], vec.lerp(start, target, 0.5))
        for _ in range(60):
            step = go.step([body], target)
        assert step.contacts
        n_ = body.normal(step.proxy)
        assert tangential(step.force, n_) < 1e-6
        assert vec.dot(step.force, n_) > 0
        again = go.step([body], target)
        assert vec.dist(again.proxy, step.proxy) < 1e-12  # settled: no drift


@pytest.mark.parametrize("r", [0.0, 0.03])
def test_sphere_and_shallow_dome_settle_on_the_true_closest_point(r):
    rng = random.Random(3)
    sph = Body("s", Sphere(0.5), Pose((0.2, 0.1, 0.3), Q))
    dome = Body("h", Hemisphere(0.6))
    for n in range(300):
        go = GodObject(r)
        if n % 2:
            body, R, c = sph, 0.5, (0.2, 0.1, 0.3)
            depth = rng.uniform(0.001, 0.35)
            u = vec.normalize(tuple(rng.gauss(0, 1) for _ in range(3)))
        else:
            body, R, c = dome, 0.6, (0.0, 0.0, 0.0)
            depth = rng.uniform(0.0005, 0.06)  # shallow
            th = rng.uniform(0.0, 1.1)
            ph = rng.uniform(0, 2 * math.pi)
            u = (math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th))
        hip = vec.add(c, vec.scale(u, R + r - depth))
        # enter at a different point of the surface, then move to the hold position
        v = vec.normalize(vec.add(u, tuple(rng.uniform(-0.3, 0.3) for _ in range(3))))
        if body is dome and v[2] < 0.2:
            v = u
        go.step([body], vec.add(c, vec.scale(v, R + r + 0.1)))
        go.step([body], vec.add(c, vec.scale(v, R + r - depth)))
        for _ in range(30):
            step = go.step([body], hip)
        truth = vec.add(c, vec.scale(u, R + r))
        assert vec.dist(step.proxy, truth) < 1e-6
        assert tangential(step.force, body.normal(step.proxy)) < 1e-6


def penalty_proxy(body, hip, r):
    """CHAI3D-style potential field: nearest (dilated) surface point while inside."""
    if phi(body, hip, r) < 0:
        return vec.add(body.closest_point(hip), vec.scale(body.normal(hip), r))
    return hip


@pytest.mark.parametrize("r", [0.0, 0.002])
@pytest.mark.parametrize("angle_deg", [0, 20, 45, 70])
def test_fast_hip_never_crosses_a_thin_box(r, angle_deg):
    """1 mm slab, HIP at 10 m/s (10 mm per 1 ms tick), several phases and angles: the
    god-object stays on top and keeps pushing up; the penalty rule on the same samples ends
    below the slab with no force (popped through), so the check can fail."""
    box = Body("thin", Box((0.4, 0.4, 0.001)))
    top, bottom = 0.0005 + r, -0.0005 - r
    a = math.radians(angle_deg)
    d = (0.0, math.sin(a), -math.cos(a))
    for offset in (0.0, 0.0003, 0.0017, 0.0041, 0.0066, 0.0099):
        go = GodObject(r)
        hip = vec.add((0.01, -0.06 * math.sin(a), 0.05), vec.scale(d, offset))
        pen = hip
        for _ in range(math.ceil(0.07 / (0.01 * math.cos(a))) + 1):
            step = go.step([box], hip)
            pen = penalty_proxy(box, hip, r)
            assert step.proxy[2] >= top - 1e-9 or (step.proxy == hip and hip[2] > top)
            if hip[2] < top:
                assert step.contacts and step.force[2] > 0  # pushing up, from above
            hip = vec.add(hip, vec.scale(d, 0.010))
        assert hip[2] < bottom - 0.01 and step.force[2] > 10.0
        assert pen[2] < bottom  # the penalty rule popped through: proxy = HIP below the slab
    # nearest-face rule also flips once the HIP passes the mid-plane (slower crossing)
    h = (0.0, 0.0, -0.0003 - r)
    assert penalty_proxy(box, h, r)[2] == pytest.approx(bottom)
    go = GodObject(r)
    go.step([box], (0.0, 0.0, 0.01))
    assert go.step([box], h).proxy[2] == pytest.approx(top, abs=1e-12)


def _crease_scene():
    ground = Body("ground", Plane((3.0, 3.0)))
    box = Body("box", Box((0.4, 0.4, 0.4)), Pose((0.0, 1.0, 0.2)))
    return [box, ground], [ground, box]


@pytest.mark.parametrize("r", [0.0, 0.01])
@pytest.mark.parametrize("order", [0, 1])
@pytest.mark.parametrize("aim", [(0.0, 0.0), (0.01, -0.004), (-0.006, 0.007)])
def test_concave_crease_in_one_tick_and_no_drift(r, order, aim):
    bodies = _crease_scene()[order]
    box = next(b for b in bodies if b.id == "box")
    ground = next(b for b in bodies if b.id == "ground")
    crease = (0.05, 1.2 + r, r)  # crease line of the dilated bodies runs along x
    for k in range(5):
        go = GodObject(r)
        x0 = 0.05 + 0.02 * k
        start = (x0, crease[1] + 0.05 + aim[0], crease[2] + 0.05 + aim[1])
        hip = (x0 + 0.003 * k, crease[1] - 0.01, crease[2] - 0.01)  # straight into the crease
        assert go.step(bodies, start).contacts == ()
        step = go.step(bodies, hip)  # ONE step
        for body in (box, ground):
            assert abs(phi(body, step.proxy, r)) <= 1e-9
        assert abs(step.force[0]) < 1e-6  # no tangential force along the crease
        assert {c.body_id for c in step.contacts} == {"box", "ground"}
        assert step.force[1] > 0 and step.force[2] > 0
        first = step.proxy
        for _ in range(1000):
            step = go.step(bodies, hip)
        assert step.proxy == first
        # sliding along the crease: the proxy follows in x exactly, stays in the crease
        for i in range(50):
            step = go.step(bodies, (hip[0] + 0.001 * i, hip[1], hip[2]))
            assert abs(step.force[0]) < 1e-6
            assert abs(phi(box, step.proxy, r)) <= 1e-9 and abs(phi(ground, step.proxy, r)) <= 1e-9


@pytest.mark.parametrize("name", sorted(SHAPES))
@pytest.mark.parametrize("r", [0.0, 0.02])
def test_force_on_the_first_tick_of_contact(name, r):
    rng = random.Random(9)
    _, extent = SHAPES[name]
    for body in bodies_for(name):
        for _ in range(20):
            go = GodObject(r)
            outside = random_outside(rng, body, r, extent)
            inside = random_inside(rng, body, r, extent)
            go.step([body], outside)
            step = go.step([body], inside)
            assert step.contacts and vec.norm(step.force) > 0
            assert abs(phi(body, step.proxy, r)) <= 1e-9


@pytest.mark.parametrize("r", [0.0, 0.01])
def test_proxy_sits_on_the_surface_without_epsilon(r):
    box = Body("box", Box((0.4, 0.4, 0.4)), Pose((0.0, 0.0, 0.2)), stiffness_n_per_m=350.0)
    for depth in (1e-6, 0.001, 0.013, 0.1):
        go = GodObject(r)
        go.step([box], (0.03, -0.02, 0.5))
        step = go.step([box], (0.05, 0.01, 0.4 + r - depth))
        assert abs(phi(box, step.proxy, r)) <= 1e-9
        assert step.proxy[2] == pytest.approx(0.4 + r, abs=1e-12)
        assert abs(vec.norm(step.force) - 350.0 * depth) <= 1e-9
        assert step.contacts[0].depth == pytest.approx(depth, abs=1e-12)
        assert step.contacts[0].normal == pytest.approx((0, 0, 1), abs=1e-15)


AXIS_CASES = [
    ("sphere pole", Body("s", Sphere(0.5)), (0, 0, 1), (0, 0, 0.4)),
    ("hemisphere pole", Body("h", Hemisphere(0.5)), (0, 0, 1), (0, 0, 0.3)),
    ("cone apex", Body("k", Cone(0.4, 0.7)), (0, 0, 1.2), (0, 0, 0.5)),
    ("cylinder top axis", Body("c", Cylinder(0.3, 0.6)), (0, 0, 1), (0, 0, 0.5)),
    ("box edge", Body("b", Box((0.6, 0.4, 0.3))), (0.5, 0, 0.35), (0.2, 0, 0.05)),
    ("box edge vertical", Body("b", Box((0.6, 0.4, 0.3))), (0.3, 0, 0.5), (0.2999, 0, 0.1)),
    ("box corner", Body("b", Box((0.6, 0.4, 0.3))), (0.5, 0.4, 0.35), (0.2, 0.1, 0.05)),
    ("cylinder rim", Body("c", Cylinder(0.3, 0.6)), (0.5, 0, 0.8), (0.2, 0, 0.5)),
    ("cone rim", Body("k", Cone(0.4, 0.7)), (0.6, 0, -0.2), (0.3, 0, 0.05)),
    ("hemisphere rim", Body("h", Hemisphere(0.5)), (0.7, 0, -0.2), (0.4, 0, 0.05)),
]


@pytest.mark.parametrize("case", AXIS_CASES, ids=[c[0] for c in AXIS_CASES])
@pytest.mark.parametrize("r", [0.0, 0.02])
def test_approach_exactly_along_an_axis_or_onto_an_edge_collides(case, r):
    _, body, a, b = case
    for n in (1, 3, 10):  # in one tick, or a few
        go = GodObject(r)
        go.step([body], a)
        for i in range(1, n + 1):
            hip = vec.lerp(a, b, i / n)
            step = go.step([body], hip)
            assert phi(body, step.proxy, r) >= -1e-9
        assert step.contacts and vec.norm(step.force) > 0
        assert abs(phi(body, step.proxy, r)) <= 1e-9
        if a[0] == a[1] == b[0] == b[1] == 0:  # on the axis: symmetric, straight up
            assert step.force[0] == 0 and step.force[1] == 0 and step.force[2] > 0


def test_friction_sticks_then_slips():
    ground = Body("g", Plane((2, 2)), static_friction=0.5, dynamic_friction=0.3)
    go = GodObject(0.0)
    go.step([ground], (0.0, 0.0, 0.05))
    step = go.step([ground], (0.0, 0.0, -0.01))  # press 10 mm
    landed = step.proxy
    assert landed == (0.0, 0.0, 0.0)
    for dx in (0.001, 0.002, 0.004, 0.0049):  # |f_t| / f_n <= 0.49 < mu_s: sticks
        step = go.step([ground], (dx, 0.0, -0.01))
        assert step.proxy == landed
        assert step.force[0] == pytest.approx(-1000 * dx)
    step = go.step([ground], (0.0065, 0.0, -0.01))  # beyond the static cone: slips
    assert step.proxy != landed
    assert step.proxy[0] == pytest.approx(0.0065 - 0.3 * 0.01, abs=1e-12)  # lags mu_d*depth
    assert abs(phi(ground, step.proxy, 0.0)) <= 1e-12
    for i in range(1, 20):  # keeps slipping while dragged, always lagging by mu_d * depth
        step = go.step([ground], (0.0065 + 0.001 * i, 0.0, -0.01))
        assert step.proxy[0] == pytest.approx(0.0065 + 0.001 * i - 0.003, abs=1e-12)
    held = step.proxy  # stop: inside the dynamic cone again -> sticks (hysteresis)
    hip = (0.0065 + 0.019, 0.0, -0.01)
    for _ in range(5):
        assert go.step([ground], hip).proxy == held
    frictionless = GodObject(0.0)
    frictionless.step([Body("g", Plane((2, 2)))], (0.0, 0.0, 0.05))
    assert frictionless.step([Body("g", Plane((2, 2)))], (0.004, 0.0, -0.01)).proxy == (
        0.004, 0.0, 0.0)


def test_reset_pushes_out_and_moving_bodies_carry_the_proxy():
    go = GodObject(0.0)
    sph = Body("s", Sphere(0.5))
    go.reset((0.0, 0.0, 0.4), [sph])
    assert go.proxy == pytest.approx((0.0, 0.0, 0.5), abs=1e-15)
    go = GodObject(0.0)
    step = go.step([sph], (0.0, 0.0, 0.3))  # first call inside: pushed out, then contact
    assert step.proxy == pytest.approx((0.0, 0.0, 0.5), abs=1e-15) and step.contacts
    moved = Body("s", Sphere(0.5), Pose((0.0, 0.0, 0.1)))  # the sphere moved up into it
    step = go.step([moved], (0.0, 0.0, 0.3))
    assert step.proxy == pytest.approx((0.0, 0.0, 0.6), abs=1e-15)
    with pytest.raises(ValueError):
        GodObject(-1.0)
    with pytest.raises(ValueError):
        GodObject(0.0, max_iterations=0)
    assert GodObject().step([], (1.0, 2.0, 3.0)).separation == math.inf


def test_timing_sanity_print():
    """Not an assertion: prints the per-step cost on this machine (benchmarks live elsewhere)."""
    bodies = [Body("hemi", Hemisphere(0.6)), Body("ground", Plane((3.0, 3.0)))]
    for label, r, path in [
        ("free", 0.06, [(0.0, 1.0, 1.0 + 1e-4 * i) for i in range(3000)]),
        ("dome contact", 0.06, [(0.0, 0.655 * math.sin(-1 + 1e-3 * i),
                                 0.655 * math.cos(-1 + 1e-3 * i)) for i in range(2000)])]:
        go = GodObject(r)
        ts = []
        for h in path:
            t0 = time.perf_counter_ns()
            go.step(bodies, h)
            ts.append(time.perf_counter_ns() - t0)
        ts.sort()
        print(f"\n{label}: p50 {ts[len(ts) // 2] / 1000:.1f} us, p99 "
              f"{ts[int(len(ts) * 0.99)] / 1000:.1f} us")
