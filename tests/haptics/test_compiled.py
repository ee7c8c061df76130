"""The compiled haptic core (_chaptics.c) gives the Python reference's numbers.

Random paths (numpy draws them, seeded) run through ``ReferenceGodObject`` and ``CompiledGodObject``
side by side; every tick's proxy, force, contacts, separation and iteration count must agree to
1e-12 (relative above 1). 10^5 paths per primitive, over the variants that take different code:
point and sphere proxies, identity and rotated poses, a body glued to the ground (crease, glued
faces), a rough neighbour (friction), and a start inside (push-out). The broad phase is checked on
scenes of many bodies, where it skips most of them.

Time: the 6 x 10^5 paths take about 90 s of CPU on the project machine (10-45 s per primitive,
nearly all of it the Python reference's steps), hence ``slow``; VIESTAC_CORE_PATHS=N runs N per primitive.
"""

from __future__ import annotations

import math
import os
import time

import numpy as np
import pytest

from server.bench.objects import cluttered_scene
from server.core.haptics.compiled import COMPILED, chaptics
from server.core.haptics.primitives import Body, Box, Cone, Cylinder, Hemisphere, Plane, Pose, Sphere

from .implementations import NOT_BUILT

pytestmark = pytest.mark.skipif(not COMPILED, reason=NOT_BUILT)

if COMPILED:
    from server.core.haptics.god_object import CompiledGodObject, ReferenceGodObject

PATHS = int(os.environ.get("VIESTAC_CORE_PATHS", 100_000))  # per primitive
TICKS = 4  # samples per path: outside, then into and around the body
TOL = 1e-12
Q = (0.9238795325112867, 0.2126311, -0.1876923, 0.25)

SHAPES = {  # shape, extent (half size around its centre), local centre
    "sphere": (Sphere(0.5), 0.5, (0.0, 0.0, 0.0)),
    "box": (Box((0.6, 0.4, 0.3)), 0.45, (0.0, 0.0, 0.0)),
    "cylinder": (Cylinder(0.3, 0.6), 0.55, (0.0, 0.0, 0.3)),
    "cone": (Cone(0.4, 0.7), 0.6, (0.0, 0.0, 0.25)),
    "plane": (Plane((1.5, 1.0)), 0.9, (0.0, 0.0, -0.2)),
    "hemisphere": (Hemisphere(0.5), 0.5, (0.0, 0.0, 0.2)),
}


def variants(name):
    """Scenes for one primitive: alone, rotated, standing on the ground, with a rough neighbour."""
    shape, _, _ = SHAPES[name]
    lift = 0.0 if name in ("cylinder", "cone", "hemisphere", "plane") else (
        0.5 if name == "sphere" else 0.15)
    ground = Body("ground", Plane((4.0, 4.0)), Pose((0.0, 0.0, -lift if name != "plane" else -0.5)))
    rough = Body("rough", Sphere(0.2), Pose((0.45, 0.1, 0.3)), 700.0, 0.5, 0.3)
    return [
        [Body(name, shape)],
        [Body(name, shape, Pose((0.1, -0.2, 0.05), Q))],
        [Body(name, shape), ground],
        [Body(name, shape, Pose((0.1, -0.2, 0.05), Q), 400.0, 0.6, 0.4), rough, ground],
    ]


def assert_same(a, b, where):
    assert a.iterations == b.iterations, where
    assert len(a.contacts) == len(b.contacts), where
    got = [*a.proxy, *a.force, a.separation]
    want = [*b.proxy, *b.force, b.separation]
    for ca, cb in zip(a.contacts, b.contacts):
        assert ca.body_id == cb.body_id, where
        got += [*ca.normal, ca.depth, *ca.point]
        want += [*cb.normal, cb.depth, *cb.point]
    for g, w in zip(got, want):
        if g != w and not abs(g - w) <= TOL * max(1.0, abs(w)):
            pytest.fail(f"{where}: compiled {a} != reference {b}")


def run_paths(scenes, centre, extent, n, seed):
    """n random paths through scenes[i % len(scenes)]; radius alternates 0 / 0.03 every path pair."""
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    starts = np.asarray(centre) + u * (extent * rng.uniform(1.05, 2.0, size=(n, 1)) + 0.03)
    inside_start = rng.uniform(size=n) < 0.05  # a few start inside: the first step pushes out
    starts[inside_start] = np.asarray(centre) + rng.uniform(-extent, extent, size=(int(inside_start.sum()), 3))
    targets = np.asarray(centre) + rng.uniform(-extent, extent, size=(n, 3))
    jumps = rng.uniform(-0.25, 0.25, size=(n, TICKS - 2, 3)) * extent
    k1 = rng.integers(1, 3, size=n)  # enter in one tick or two
    hips = np.empty((n, TICKS, 3))
    hips[:, 0] = starts
    hips[:, 1] = np.where(k1[:, None] == 1, targets, 0.5 * (starts + targets))
    hips[:, 2] = np.where(k1[:, None] == 1, targets + jumps[:, 0], targets)
    for t in range(3, TICKS):
        hips[:, t] = hips[:, t - 1] + jumps[:, t - 2]
    paths = hips.tolist()
    contacts = 0
    for i, path in enumerate(paths):
        bodies = scenes[i % len(scenes)]
        r = 0.0 if (i // len(scenes)) % 2 == 0 else 0.03
        ref, comp = ReferenceGodObject(r), CompiledGodObject(r)
        for t, hip in enumerate(path):
            a, b = comp.step(bodies, hip), ref.step(bodies, hip)
            assert_same(a, b, f"path {i} tick {t} r={r} scene {i % len(scenes)}")
            contacts += bool(b.contacts)
            assert comp.sticking == ref.sticking
    return contacts


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SHAPES))
def test_compiled_god_object_equals_the_reference_on_random_paths(name):
    """10^5 paths per primitive (see the module docstring for the time it takes)."""
    _, extent, local_centre = SHAPES[name]
    t0 = time.perf_counter()
    contacts = run_paths(variants(name), local_centre, extent, PATHS, seed=sorted(SHAPES).index(name))
    assert contacts > PATHS // 2  # the paths do touch the body (and not only once)
    print(f"\n{name}: {PATHS} paths in {time.perf_counter() - t0:.1f} s")


@pytest.mark.parametrize("n, kind", [(10, list), (200, tuple)])
def test_the_broad_phase_keeps_the_results_on_many_bodies(n, kind):
    """A hand wandering over a cluttered table, touching and leaving objects: the compiled core
    (which skips far bodies by their bounding balls) gives the reference's numbers every tick."""
    bodies = kind(cluttered_scene(n, seed=n))
    touched = 0
    for r in (0.0, 0.02):
        ref, comp = ReferenceGodObject(r), CompiledGodObject(r)
        for walk in range(6):
            target = bodies[1 + walk * 7 % n].pose.pos
            for i in range(300):  # down onto the object, then a slow circle through it
                s = i / 100.0
                hip = (target[0] + 0.3 * (1 - min(s, 1)) + 0.05 * math.sin(s),
                       target[1] - 0.2 * (1 - min(s, 1)) + 0.05 * math.cos(3 * s), 0.4 - 0.35 * min(s, 1) + 0.01 * s)
                a, b = comp.step(bodies, hip), ref.step(bodies, hip)
                assert_same(a, b, f"n={n} r={r} walk {walk} tick {i}")
                touched += bool(b.contacts)
    assert touched > 500


def test_primitives_evaluate_and_cast_like_the_reference():
    """The compiled sd/normal and cast of every primitive are the reference's, bit for bit."""
    rng = np.random.default_rng(7)
    for name, (shape, extent, centre) in SHAPES.items():
        for pose in (Pose(), Pose((0.1, -0.2, 0.05), Q)):
            body = Body(name, shape, pose)
            pts = (np.asarray(pose.to_world(centre)) + rng.uniform(-1.5, 1.5, size=(20_000, 3)) * extent).tolist()
            pts += [[0.0, 0.0, z] for z in (-0.5, 0.0, 0.25, 0.7, 1.0)]  # on the axis: the tie-breaks
            for p in pts:
                assert chaptics.evaluate(body, p) == body._eval(tuple(p)), (name, p)
            for a, b in zip(pts[::2], pts[1::2]):
                for radius in (0.0, 0.03):
                    assert chaptics.cast(body, a, b, radius) == body.cast(a, b, radius), (name, a, b, radius)


def test_bodies_the_core_does_not_know_take_the_reference_step():
    """A body whose shape is not one of the six primitives (the bench's mesh and grid baselines)
    runs the reference step on the compiled object's state."""
    from server.bench.mesh_shape import MeshShape

    mesh = [Body("m", MeshShape.of(Sphere(0.5), 2))]
    comp, ref = CompiledGodObject(0.0), ReferenceGodObject(0.0)
    for hip in [(0.0, 0.0, 1.0), (0.05, 0.0, 0.3), (0.1, 0.02, 0.2)]:
        assert_same(comp.step(mesh, hip), ref.step(mesh, hip), hip)
    assert comp.proxy == ref.proxy


def test_copies_and_pickles_carry_the_compiled_state():
    """The compiled objects keep their state in C: a deep copy or a pickle (a study sent to a
    worker process) continues exactly where the original was."""
    import copy
    import pickle

    from server.core.haptics.contact_gate import ContactGate

    ground = [Body("g", Plane((2.0, 2.0)), static_friction=0.5, dynamic_friction=0.3)]
    god, gate = CompiledGodObject(0.01, max_iterations=9), ContactGate(0.003, 0.02, 0.04)
    for i, hip in enumerate([(0.0, 0.0, 0.05), (0.0, 0.0, -0.01), (0.002, 0.0, -0.01)]):
        s = god.step(ground, hip)
        gate.update(0.001 * i, bool(s.contacts), s.separation)
    assert god.sticking and gate.on
    for twin_god, twin_gate in [(copy.deepcopy(god), copy.deepcopy(gate)),
                                (pickle.loads(pickle.dumps(god)), pickle.loads(pickle.dumps(gate)))]:
        assert (twin_god.radius, twin_god.max_iterations, twin_god.proxy, twin_god.sticking) == (
            0.01, 9, god.proxy, True)
        assert (twin_gate.band, twin_gate.min_off_s, twin_gate.on, twin_gate._t_change) == (0.003, 0.04, True, 0.001)
        hip = (0.009, 0.0, -0.01)
        assert_same(twin_god.step(ground, hip), copy.deepcopy(god).step(ground, hip), "copy")
