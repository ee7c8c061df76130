"""Property tests for server.core.haptics.primitives and vec: exact SDFs, poses, casts, dicts.

Oracles are independent of the implementation where it matters: the surface is checked with
the max-of-constraints boundary function (zero exactly on the boundary), the sign with plain
inside predicates, exactness against parametric surface samples, casts against dense sampling.
"""

from __future__ import annotations

import math
import random

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from server.core.haptics import vec
from server.core.haptics.primitives import (Body, Box, Cone, Cylinder, Hemisphere, Plane, Pose,
                                       Sphere, shape_from_dict)

SETTINGS = settings(derandomize=True, database=None, deadline=None, max_examples=300,
                    suppress_health_check=[HealthCheck.too_slow])

dims = st.floats(0.05, 2.0)
shapes = st.one_of(
    st.builds(Sphere, dims), st.builds(Box, st.tuples(dims, dims, dims)),
    st.builds(Cylinder, dims, dims), st.builds(Cone, dims, dims),
    st.builds(Plane, st.tuples(dims, dims)), st.builds(Hemisphere, dims))
coord = st.one_of(st.floats(-3.0, 3.0), st.just(0.0), st.floats(-1e-9, 1e-9))
points = st.tuples(coord, coord, coord)


def _unit_quat(q):
    n = math.sqrt(sum(c * c for c in q))
    return tuple(c / n for c in q) if n > 1e-3 else (1.0, 0.0, 0.0, 0.0)


poses = st.builds(lambda p, q: Pose(p, _unit_quat(q)),
                  st.tuples(*[st.floats(-2, 2)] * 3), st.tuples(*[st.floats(-1, 1)] * 4))


def boundary(shape, p):
    """Max of the shape's constraint functions: < 0 inside, 0 exactly on the surface."""
    x, y, z = p
    rho = math.hypot(x, y)
    if isinstance(shape, Sphere):
        return math.dist(p, (0, 0, 0)) - shape.radius
    if isinstance(shape, Box):
        return max(abs(c) - s / 2 for c, s in zip(p, shape.size))
    if isinstance(shape, Plane):
        return max(abs(x) - shape.size[0] / 2, abs(y) - shape.size[1] / 2, z)
    if isinstance(shape, Cylinder):
        return max(rho - shape.radius, -z, z - shape.height)
    if isinstance(shape, Cone):
        r, h = shape.radius, shape.height
        return max(-z, (h * rho + r * z - r * h) / math.hypot(r, h))
    return max(math.dist(p, (0, 0, 0)) - shape.radius, -z)  # hemisphere


def surface_samples(shape, n=60):
    """Points on the surface from the shape's parametrisation (faces, rims, edges, apex)."""
    out = []
    ts = [i / (n - 1) for i in range(n)]
    if isinstance(shape, (Sphere, Hemisphere)):
        R = shape.radius
        for a in ts:
            th = math.pi * a if isinstance(shape, Sphere) else math.pi / 2 * a
            for b in ts:
                ph = 2 * math.pi * b
                out.append((R * math.sin(th) * math.cos(ph), R * math.sin(th) * math.sin(ph),
                            R * math.cos(th)))
        if isinstance(shape, Hemisphere):
            out += [(R * a * math.cos(2 * math.pi * b), R * a * math.sin(2 * math.pi * b), 0.0)
                    for a in ts for b in ts]
    elif isinstance(shape, (Box, Plane)):
        hx, hy = shape.size[0] / 2, shape.size[1] / 2
        hz = shape.size[2] / 2 if isinstance(shape, Box) else None
        zlo, zhi = (-hz, hz) if hz is not None else (-3.0, 0.0)
        for a in ts:
            for b in ts:
                u, v = -1 + 2 * a, -1 + 2 * b
                out += [(u * hx, v * hy, zhi), (u * hx, hy, zlo + (zhi - zlo) * b),
                        (u * hx, -hy, zlo + (zhi - zlo) * b), (hx, v * hy, zlo + (zhi - zlo) * a),
                        (-hx, v * hy, zlo + (zhi - zlo) * a)]
                if hz is not None:
                    out.append((u * hx, v * hy, -hz))
    else:  # cylinder, cone
        R, H = shape.radius, shape.height
        for a in ts:
            for b in ts:
                ph = 2 * math.pi * b
                c, s = math.cos(ph), math.sin(ph)
                z = H * a
                rr = R if isinstance(shape, Cylinder) else R * (1 - a)
                out += [(rr * c, rr * s, z), (R * a * c, R * a * s, 0.0)]
                if isinstance(shape, Cylinder):
                    out.append((R * a * c, R * a * s, H))
    return out


def inside(shape, p):
    return boundary(shape, p) < 0


@SETTINGS
@given(shapes, points)
def test_closest_point_on_surface_idempotent_and_exact(shape, p):
    sd = shape.signed_distance(p)
    cp = shape.closest_point(p)
    assert abs(boundary(shape, cp)) <= 1e-9  # independent surface test
    assert abs(shape.signed_distance(cp)) <= 1e-9
    assert vec.dist(shape.closest_point(cp), cp) <= 1e-9  # projection is idempotent
    assert abs(abs(sd) - vec.dist(p, cp)) <= 1e-9  # |sd| is the distance to a surface point
    b = boundary(shape, p)
    if abs(b) > 1e-9:  # sign from an independent inside test
        assert (sd < 0) == (b < 0)
    n = shape.normal(p)
    assert abs(vec.norm(n) - 1.0) <= 1e-9


@SETTINGS
@given(shapes, points, points)
def test_one_lipschitz_and_never_above_the_distance_to_surface_points(shape, p, q):
    assert abs(shape.signed_distance(p) - shape.signed_distance(q)) <= vec.dist(p, q) + 1e-12
    s = shape.closest_point(q)  # a surface point: |sd(p)| can never exceed |p - s|
    assert abs(shape.signed_distance(p)) <= vec.dist(p, s) + 1e-9


@pytest.mark.parametrize("shape", [Sphere(0.5), Box((0.6, 0.4, 0.3)), Cylinder(0.3, 0.7),
                                   Cone(0.4, 0.7), Cone(1.0, 0.2), Plane((1.5, 1.0)),
                                   Hemisphere(0.5)])
def test_exact_against_parametric_surface_samples(shape):
    """Exact, not a bound: |sd| <= distance to every sampled surface point, and equal to the
    distance to one boundary point (previous test), so sd is the Euclidean distance."""
    samples = surface_samples(shape)
    for s in samples[::7]:
        assert abs(boundary(shape, s)) <= 1e-12
    rng = random.Random(7)
    spacing = 0.0
    for _ in range(150):
        p = tuple(rng.uniform(-1.2, 1.2) for _ in range(3))
        best = min(vec.dist(p, s) for s in samples)
        sd = shape.signed_distance(p)
        assert abs(sd) <= best + 1e-12
        spacing = max(spacing, best - abs(sd))
    assert spacing < 0.05  # the samples are dense enough for the bound to be meaningful


def _smooth_at(shape, p, h):
    n = shape.normal(p)
    for i in range(3):
        for sgn in (-1, 1):
            q = list(p)
            q[i] += sgn * 10 * h
            if vec.dist(shape.normal(tuple(q)), n) > 1e-3:
                return False
    return True


@SETTINGS
@given(shapes, points)
def test_normal_is_the_gradient_away_from_edges(shape, p):
    h = 1e-6
    if not _smooth_at(shape, p, h):
        return
    fd = []
    for i in range(3):
        a, b = list(p), list(p)
        a[i] += h
        b[i] -= h
        fd.append((shape.signed_distance(tuple(a)) - shape.signed_distance(tuple(b))) / (2 * h))
    assert vec.dist(tuple(fd), shape.normal(p)) <= 1e-5


@SETTINGS
@given(shapes, poses, points)
def test_pose_invariance(shape, pose, p):
    body = Body("b", shape, pose)
    w = pose.to_world(p)
    assert vec.dist(pose.to_local(w), p) <= 1e-12
    assert abs(body.signed_distance(w) - shape.signed_distance(p)) <= 1e-9
    lp = pose.to_local(w)  # ties (axis points, equidistant faces) may flip on 1e-16 changes
    if vec.dist(shape.normal(lp), shape.normal(p)) <= 1e-10:
        tol = 1e-9 * (1.0 + abs(shape.signed_distance(p)))  # cp = p - sd n: n error scales
        assert vec.dist(body.closest_point(w), pose.to_world(shape.closest_point(p))) <= tol
        assert vec.dist(body.normal(w), pose.rotate(shape.normal(p))) <= 1e-9
        assert vec.dist(pose.unrotate(body.normal(w)), shape.normal(p)) <= 1e-9


@SETTINGS
@given(shapes, poses)
def test_dict_round_trips(shape, pose):
    assert shape_from_dict(shape.to_dict()) == shape
    assert shape.to_dict()["type"] == shape.type
    assert Pose.from_dict(pose.to_dict()) == pose


@pytest.mark.parametrize("d", [
    {"type": "torus", "radius": 1}, {"radius": 1}, {"type": "sphere"},
    {"type": "sphere", "radius": 0}, {"type": "sphere", "radius": -1},
    {"type": "sphere", "radius": float("nan")}, {"type": "sphere", "radius": float("inf")},
    {"type": "sphere", "radius": "1"}, {"type": "sphere", "radius": True},
    {"type": "box", "size": [1, 1]}, {"type": "box", "size": [1, 0, 1]},
    {"type": "cylinder", "radius": 1}, {"type": "cone", "height": 1, "radius": -2},
    {"type": "plane", "size": [1, 1, 1]}, {"type": "plane", "size": "ab"},
    {"type": "hemisphere"}, "sphere", None])
def test_bad_shape_dicts_raise(d):
    with pytest.raises(ValueError):
        shape_from_dict(d)


def test_protocol_shapes_and_pose_validation():
    assert Plane((3, 3)).to_dict() == {"type": "plane", "size": [3.0, 3.0]}
    assert shape_from_dict({"type": "cone", "radius": 0.5, "height": 1}) == Cone(0.5, 1.0)
    for bad in [{"quat": [0, 0, 0, 0]}, {"quat": [1, 0, 0]}, {"pos": [0, 0, float("nan")]},
                {"pos": "abc"}, []]:
        with pytest.raises(ValueError):
            Pose.from_dict(bad)
    assert Pose((1, 2, 3), (2, 0, 0, 0)).quat == (1.0, 0.0, 0.0, 0.0)  # normalised
    half = math.sqrt(0.5)
    pz = Pose((0, 0, 0), (half, 0, 0, half))  # +90 deg about z: x -> y
    assert vec.dist(pz.rotate((1, 0, 0)), (0, 1, 0)) < 1e-15
    with pytest.raises(ValueError):
        Body("b", Sphere(1), stiffness_n_per_m=-1)
    with pytest.raises(ValueError):
        Body("", Sphere(1))


def test_degenerate_points_are_deterministic():
    # sphere centre, axis points, apex, box centre: unit normals, documented choices
    assert Sphere(1).normal((0, 0, 0)) == (0.0, 0.0, 1.0)
    assert Sphere(1).closest_point((0, 0, 0)) == (0.0, 0.0, 1.0)
    assert Cone(0.5, 1).normal((0, 0, 1)) == (0.0, 0.0, 1.0)
    assert Box((1, 1, 1)).normal((0, 0, 0)) == (0.0, 0.0, 1.0)
    for shape in [Sphere(0.5), Cylinder(0.3, 0.6), Cone(0.4, 0.7), Hemisphere(0.5)]:
        for z in [-1, -0.1, 0, 0.1, 0.3, 0.35, 0.5, 0.6, 0.7, 1.0]:
            p = (0.0, 0.0, float(z))
            assert abs(vec.norm(shape.normal(p)) - 1) < 1e-12
            assert abs(boundary(shape, shape.closest_point(p))) < 1e-12


def test_vec_helpers():
    assert vec.normalize((0.0, 0.0, 0.0)) == vec.ZERO_DIRECTION == (0.0, 0.0, 1.0)
    assert vec.normalize((3.0, 0.0, 4.0)) == (0.6, 0.0, 0.8)
    assert vec.cross((1, 0, 0), (0, 1, 0)) == (0, 0, 1)
    assert vec.lerp((0, 0, 0), (2, 4, 6), 0.5) == (1, 2, 3)
    assert vec.dot(vec.add((1, 2, 3), vec.sub((1, 1, 1), (0, 0, 0))), vec.scale((1, 0, 0), 2)) == 4
    assert vec.norm((2, 3, 6)) == 7 and vec.dist((1, 1, 1), (3, 4, 7)) == 7


def _first_inside_sample(body, a, b, radius, n=4000):
    for k in range(n + 1):
        t = k / n
        if body.signed_distance(vec.lerp(a, b, t)) - radius < -1e-9:
            return t
    return None


@pytest.mark.parametrize("radius", [0.0, 0.05])
def test_cast_matches_dense_sampling(radius):
    rng = random.Random(11)
    half = math.sqrt(0.5)
    bodies = [Body("s", Sphere(0.5), Pose((0.1, 0, 0))),
              Body("b", Box((0.6, 0.4, 0.05)), Pose((0, 0.1, 0), (half, half, 0, 0))),
              Body("c", Cylinder(0.3, 0.6)), Body("k", Cone(0.4, 0.7)),
              Body("p", Plane((1.5, 1.0))), Body("h", Hemisphere(0.5))]
    for body in bodies:
        for _ in range(120):
            a = tuple(rng.uniform(-1.5, 1.5) for _ in range(3))
            if body.signed_distance(a) - radius <= 1e-6:
                continue
            b = tuple(rng.uniform(-1.5, 1.5) for _ in range(3))
            t = body.cast(a, b, radius)
            ts = _first_inside_sample(body, a, b, radius)
            if t is None:
                assert ts is None
                continue
            p = vec.lerp(a, b, t)
            assert -1e-12 <= body.signed_distance(p) - radius <= 1e-12  # stops ON the surface
            if ts is not None:
                assert t <= ts + 1e-12
            for k in range(200):  # nothing before t is inside
                q = vec.lerp(a, b, t * k / 200)
                assert body.signed_distance(q) - radius >= -1e-12


def test_cast_from_the_surface_inward_tangential_outward():
    box = Body("b", Box((1, 1, 1)))
    top = (0.1, 0.2, 0.5)
    assert box.cast(top, (0.1, 0.2, 0.3)) == 0.0  # inward: hit at once
    assert box.cast(top, (0.4, -0.3, 0.5)) is None  # sliding along the face
    assert box.cast(top, (0.4, -0.3, 0.9)) is None  # leaving
    edge = (0.5, 0.0, 0.5)
    assert box.cast(edge, (0.9, 0.0, 0.4)) is None  # over the edge, down the outside
    assert box.cast(edge, (0.3, 0.0, 0.5)) is None  # along the top face from the edge
    assert box.cast(edge, (0.4, 0.0, 0.4)) == 0.0  # into the box
    sph = Body("s", Sphere(1))
    assert sph.cast((0, 0, 1), (1, 0, 1)) is None  # tangent to a curved surface: leaves it
    assert sph.cast((0, 0, 3), (0, 0, 0)) == pytest.approx(2 / 3, abs=1e-15)  # down the axis
    cone = Body("k", Cone(0.5, 1.0))
    assert cone.cast((0, 0, 2), (0, 0, 0.5)) == pytest.approx(2 / 3, abs=1e-15)  # onto apex
    assert cone.cast((0, 0, 1), (0, 0, 0.5)) == 0.0  # from the apex into the cone
    assert cone.cast((0, 0, 1), (0.3, 0, 0.4)) is None  # down the outside of the cone
    assert Body("p", Plane((1, 1))).cast((0, 0, 1), (0, 0, -1), 0.1) == pytest.approx(0.45)


def test_a_pose_of_plain_floats_without_rotation_is_the_same_as_one_given_the_unit_quat():
    quick, given = Pose((1.0, -2.0, 3.5)), Pose((1.0, -2.0, 3.5), (1.0, 0.0, 0.0, 0.0))
    assert quick == given and quick._m is None and given._m is None
    assert quick.to_world((0.1, 0.2, 0.3)) == given.to_world((0.1, 0.2, 0.3))
    assert Pose((1, 2, 3)).pos == (1.0, 2.0, 3.0) and type(Pose((1, 2, 3)).pos[0]) is float
    for bad in ((float("nan"), 0.0, 0.0), (0.0, float("inf"), 0.0), (1.0, 2.0)):
        with pytest.raises(ValueError):
            Pose(bad)
