"""`viestac bench accuracy`: the contact methods it compares, its truth, and its output."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from server.bench.accuracy import choose, pareto, run_accuracy_bench, scene_bodies
from server.bench.contact_methods import PenaltyMethod, ProxyMethod, build_methods, grid_bodies, mesh_bodies
from server.bench.trajectories import SCENES, scene_trajectory
from server.bench.mesh_shape import MeshShape
from server.core.haptics.primitives import Body, Box, Cone, Cylinder, Hemisphere, Plane, Pose, Sphere
from server.bench.sdf_grid import GridBody, GridShape

SHAPES = [Sphere(0.5), Hemisphere(0.6), Box((1.0, 0.6, 0.4)), Plane((3.0, 3.0)), Cylinder(0.2, 0.4),
          Cone(0.5, 1.0)]


@pytest.mark.parametrize("shape", SHAPES, ids=lambda s: s.type)
def test_a_finer_tessellation_lies_closer_to_the_primitive(shape):
    points = np.random.default_rng(7).uniform(-1.0, 1.2, (200, 3))
    worst = []
    for level in (1, 4):
        mesh = MeshShape.of(shape, level)
        worst.append(max(abs(mesh._eval(*p)[0] - shape._eval(*p)[0]) for p in points))
    if isinstance(shape, (Box, Plane)):  # flat faces: every tessellation is exact
        assert worst == pytest.approx([0.0, 0.0], abs=1e-12)
    else:
        assert worst[1] < worst[0] / 4
        assert worst[1] < 2e-3


def test_the_mesh_distance_is_the_polyhedron_distance():
    mesh = MeshShape.of(Sphere(1.0), 1)  # an icosahedron subdivided once: 80 faces, vertices on the sphere
    vertex = np.asarray(MeshShape.of(Sphere(1.0), 1)._start[0, 0])
    sd, *n = mesh._eval(*(1.5 * vertex))
    assert sd == pytest.approx(0.5, abs=1e-12)  # outside a vertex: the distance to it
    assert n == pytest.approx(list(vertex), abs=1e-12)
    sd_in, *_ = mesh._eval(0.0, 0.0, 0.0)
    assert -1.0 < sd_in < -0.79  # the inscribed polyhedron's inradius (~0.795 at 80 faces)


def test_a_grid_reproduces_a_linear_field_and_rounds_a_sphere():
    grid = GridShape(Plane((2.0, 2.0)), 16, 0.2)
    for p in [(0.1, 0.2, 0.05), (-0.5, 0.3, -0.2), (0.0, 0.0, 0.15)]:
        sd, nx, ny, nz = grid._eval(*p)
        assert sd == pytest.approx(p[2], abs=1e-7)  # exact but for the nodes' float32 storage
        assert (nx, ny, nz) == pytest.approx((0.0, 0.0, 1.0), abs=1e-6)
    coarse, fine = GridShape(Sphere(0.5), 8, 0.1), GridShape(Sphere(0.5), 32, 0.1)
    points = np.random.default_rng(3).uniform(-0.55, 0.55, (200, 3))
    err = [max(abs(g._eval(*p)[0] - (np.linalg.norm(p) - 0.5)) for p in points) for g in (coarse, fine)]
    assert err[1] < err[0] and err[1] < 0.01


def test_a_grid_cast_lands_on_the_surface_and_never_inside():
    body = GridBody("s", GridShape(Sphere(0.5), 16, 0.2), Pose((0.0, 0.0, 0.0)))
    for a, b in [((0.0, 0.0, 1.0), (0.0, 0.0, 0.0)), ((0.9, 0.3, 0.2), (-0.2, 0.0, 0.1))]:
        hit = body._cast(a, b[0] - a[0], b[1] - a[1], b[2] - a[2], 0.06, 1.0, None)
        assert hit is not None
        assert abs(hit[2][0] - 0.06) <= 1e-12
        assert body._eval(hit[1])[0] - 0.06 >= -1e-12
    assert body._cast((0.0, 0.0, 2.0), 1.0, 0.0, 0.0, 0.06, 1.0, None) is None  # passes well above


def test_the_penalty_pops_through_a_thin_plate_where_the_god_object_holds():
    plate = [Body("plate", Box((0.2, 0.2, 0.01)), Pose((0.0, 0.0, 0.0)))]
    penalty, god = PenaltyMethod(plate, 0.0), ProxyMethod("analytic", "analytic", plate, 0.0)
    path = [(0.0, 0.0, 0.02 - 0.001 * i) for i in range(30)]  # down through 1 cm at 1 m/s
    for hip in path:
        p, g = penalty.step(hip), god.step(hip)
    # past the mid-plane the nearest face is the bottom one: the penalty pushes the finger through
    assert penalty.step((0.0, 0.0, -0.004)).force[2] < 0.0
    assert g.force[2] > 0.0 and g.proxy[2] == pytest.approx(0.005)
    assert not p.contact  # below the plate the penalty feels nothing at all


def test_the_penalty_sums_both_bodies_in_a_crease():
    # a box sunk 5 cm into the ground
    bodies = [Body("ground", Plane((3.0, 3.0))), Body("box", Box((0.2, 0.2, 0.2)), Pose((0.0, 0.0, 0.05)))]
    s = PenaltyMethod(bodies, 0.0).step((0.105, 0.0, -0.01))  # under the ground beside the box
    assert s.contact and s.force == pytest.approx((0.0, 0.0, 10.0))
    s = PenaltyMethod(bodies, 0.0).step((0.095, 0.0, -0.01))  # under the ground AND inside the box
    assert s.force == pytest.approx((5.0, 0.0, 10.0))  # pushed out by both bodies at once
    assert s.proxy == pytest.approx((0.1, 0.0, 0.0))


def test_the_methods_cover_every_representation_at_several_resolutions():
    bodies, radius = scene_bodies("shape-v1")
    full = build_methods(bodies, radius)
    assert [m.family for m in full].count("mesh") == 4 and [m.family for m in full].count("sdf") == 4
    assert {m.family for m in full} == {"analytic", "mesh", "sdf", "penalty"}
    assert len({m.label for m in full}) == len(full)
    faces = [sum(b.shape.faces for b in mesh_bodies(bodies, level)) for level in (1, 2, 3, 4)]
    assert faces == sorted(faces) and faces[0] < faces[-1]
    assert all(isinstance(b.shape, GridShape) for b in grid_bodies(bodies, 16, 0.16))


@pytest.mark.parametrize("scene", SCENES)
def test_the_analytic_god_object_follows_the_closed_form_truth(scene):
    bodies, radius = scene_bodies(scene)
    traj = scene_trajectory(scene, radius, speed_scale=4.0)
    method = ProxyMethod("analytic", "analytic", bodies, radius)
    assert sum(t is not None for t in traj.truths) > len(traj.hips) / 3  # mostly in contact
    for hip, truth in zip(traj.hips, traj.truths):
        s = method.step(hip)
        assert s.contact == (truth is not None)
        if truth is not None:
            assert math.dist(s.proxy, truth) < 1e-6  # 1 µm: the crease settles within a few ticks
            assert min(b.signed_distance(truth) - radius for b in bodies) == pytest.approx(0.0, abs=1e-9)


def test_pareto_and_choice_on_hand_made_points():
    pts = [{"label": "a", "family": "analytic", "cost_p50_us": 20, "cost_p99_us": 50, "err_p99_mm": 0.0},
           {"label": "p", "family": "penalty", "cost_p50_us": 2, "cost_p99_us": 5, "err_p99_mm": 0.0},
           {"label": "m", "family": "mesh", "cost_p50_us": 200, "cost_p99_us": 900, "err_p99_mm": 1.0},
           {"label": "s", "family": "sdf", "cost_p50_us": 300, "cost_p99_us": 400, "err_p99_mm": 0.5}]
    assert pareto(pts) == ["p"]  # as accurate and cheaper than everything else
    assert choose(pts) == "a"  # equal error: the method that cannot tunnel goes first
    pts[1]["err_p99_mm"] = 5.0
    assert set(pareto(pts)) == {"a", "p"} and choose(pts) == "a"
    assert choose([dict(pts[2], cost_p50_us=400)]) is None  # nothing fits the budget


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("accuracy")
    summary = run_accuracy_bench(out, quick=True)
    return out, summary, json.loads((out / "accuracy.json").read_text())


def test_the_quick_bench_writes_finite_numbers_for_every_method(quick_run):
    out, summary, data = quick_run
    assert data["quick"] is True and data["machine"]["cores"] >= 1
    assert (out / "accuracy.png").stat().st_size > 10_000 and (out / "accuracy.svg").stat().st_size > 10_000
    assert summary["json"] == str(out / "accuracy.json")
    for s in data["scenes"].values():
        labels = [p["label"] for p in s["methods"]]
        assert {p["family"] for p in s["methods"]} == {"analytic", "mesh", "sdf", "penalty"}
        for p in s["methods"]:
            assert p["ticks"] == s["trajectory"]["ticks"] > 0
            for key in ("cost_p50_us", "cost_p99_us"):
                assert math.isfinite(p[key]) and p[key] > 0.0
            assert p["cost_p50_us"] <= p["cost_p99_us"]
            for key in ("err_p50_mm", "err_p99_mm", "err_max_mm", "force_dir_p99_deg", "contact_mismatch"):
                assert math.isfinite(p[key]) and p[key] >= 0.0
        assert s["pareto"] and set(s["pareto"]) <= set(labels) and s["choice"] in labels


def test_the_chart_puts_the_server_method_first_and_the_baselines_in_error(quick_run):
    _, summary, data = quick_run
    for s in data["scenes"].values():
        by = {p["label"]: p for p in s["methods"]}
        assert by["analytic"]["err_max_mm"] < 1e-3  # the closed-form truth, to floating point
        assert "analytic" in s["pareto"] and s["choice"] == "analytic" and s["server_follows_chart"]
        assert all(p["err_p99_mm"] > 0.1 for p in s["methods"] if p["family"] in ("mesh", "sdf"))
    # a deep press near a cube's edge: the nearest face is the side, the penalty pushes sideways
    assert next(p for p in data["scenes"]["shape-v1"]["methods"] if p["family"] == "penalty")["err_max_mm"] > 50
    assert summary["server follows chart"] is True


def test_an_output_path_that_is_a_file_is_refused_before_any_work(tmp_path, capsys):
    from server.cli import main

    target = tmp_path / "taken"
    target.write_text("keep me")
    assert main(["bench", "accuracy", "--quick", "--out", str(target)]) == 2
    assert "is not a directory" in capsys.readouterr().err
    assert target.read_text() == "keep me"
