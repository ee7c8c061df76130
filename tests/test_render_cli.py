"""`viestac render`: a recorded trajectory through a named scenario or a scene file."""

import csv
import json
import math
import subprocess
import sys

import pytest

from server.loop.simulation import Simulation
from scenarios.contact_angle import ContactAngle


def _write_trajectory(path, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["t", "x", "y", "z"])
        w.writerows(rows)


def _viestac(*args):
    return subprocess.run([sys.executable, "-m", "server.cli", *args], capture_output=True, text=True, timeout=120)


def test_render_contact_angle_matches_live_simulation(tmp_path):
    # A 0.5 s press straight down onto the top of the dome, sampled at 120 Hz.
    rows = [(i / 120, 0.0, 0.0, 1.0 - 0.8 * i / 60) for i in range(61)]
    traj, out = tmp_path / "in.csv", tmp_path / "out.csv"
    _write_trajectory(traj, rows)
    result = _viestac("render", "--scene", "contact-angle", "--trajectory", str(traj), "--out", str(out))
    assert result.returncode == 0, result.stderr
    with open(out) as f:
        table = list(csv.DictReader(f))
    assert len(table) == 501  # 0 .. 0.5 s at 1 kHz
    first_contact = next(r for r in table if r["contact"] == "1")
    assert json.loads(first_contact["cues"]) == [{"kind": "tilt", "direction_deg": 0, "magnitude_pct": 100}]
    for r in table:
        proxy = tuple(float(r[k]) for k in ("proxy_x", "proxy_y", "proxy_z"))
        # The proxy never enters the dome dilated by the proxy radius.
        assert math.dist(proxy, (0, 0, 0)) >= 0.66 - 1e-8 or proxy[2] < 0
    # Same inputs, same outputs: the live simulation with the same zero-order hold agrees.
    sim = Simulation(ContactAngle())
    index = 0
    for r in table:
        t = int(r["tick"]) / 1000
        while index + 1 < len(rows) and rows[index + 1][0] <= t + 1e-12:
            index += 1
        sim.set_hip(rows[index][1:])
        live = sim.step()
        assert float(r["proxy_z"]) == pytest.approx(live.proxy[2], abs=1e-8)


def test_render_custom_scene_file(tmp_path):
    scene = {"name": "thin-wall", "objects": [
        {"id": "wall", "shape": {"type": "box", "size": [0.001, 1, 1]}, "pose": {"pos": [0, 0, 0], "quat": [1, 0, 0, 0]}}],
        "hip": {"radius": 0.0, "proxy_radius": 0.0}}
    scene_path = tmp_path / "scene.json"
    scene_path.write_text(json.dumps(scene))
    # 10 m/s straight through a 1 mm wall: 10 mm per tick.
    rows = [(i / 1000, 0.05 - 0.01 * i, 0.0, 0.0) for i in range(11)]
    traj, out = tmp_path / "in.csv", tmp_path / "out.csv"
    _write_trajectory(traj, rows)
    result = _viestac("render", "--scene", str(scene_path), "--trajectory", str(traj), "--out", str(out))
    assert result.returncode == 0, result.stderr
    with open(out) as f:
        table = list(csv.DictReader(f))
    assert all(float(r["proxy_x"]) >= 0.0005 - 1e-9 for r in table)
    assert float(table[-1]["hip_x"]) < -0.04 and table[-1]["touching"] == "wall"


@pytest.mark.parametrize("content, message", [
    ("t,x,y\n0,0,0\n", "missing column"),
    ("t,x,y,z\n0,0,0,nan\n", "NaN"),
    ("t,x,y,z\n1,0,0,0\n0,0,0,0\n", "backwards"),
    ("t,x,y,z\n", "no samples"),
])
def test_render_rejects_bad_trajectories(tmp_path, content, message):
    traj = tmp_path / "in.csv"
    traj.write_text(content)
    result = _viestac("render", "--scene", "contact-angle", "--trajectory", str(traj), "--out", str(tmp_path / "o.csv"))
    assert result.returncode == 2 and message in result.stderr


def test_render_rejects_bad_scene(tmp_path):
    scene_path = tmp_path / "bad.json"
    scene_path.write_text(json.dumps({"name": "x", "objects": [{"id": "a", "shape": {"type": "torus"}}]}))
    traj = tmp_path / "in.csv"
    _write_trajectory(traj, [(0, 0, 0, 1)])
    result = _viestac("render", "--scene", str(scene_path), "--trajectory", str(traj), "--out", str(tmp_path / "o.csv"))
    assert result.returncode == 2 and "torus" in result.stderr
    result = _viestac("render", "--scene", "contact-angel", "--trajectory", str(traj), "--out", str(tmp_path / "o.csv"))
    assert result.returncode == 2 and "did you mean" in result.stderr


def test_render_stops_at_a_failing_tick_with_the_scenarios_error(tmp_path):
    from server.render import render

    class Broken(ContactAngle):
        def step(self, ctx):
            if ctx.tick == 3:
                raise ValueError("scenario bug at tick 3")
            return super().step(ctx)

    with pytest.raises(RuntimeError, match="(?s)tick 3 failed.*scenario bug at tick 3"):
        render(Simulation(Broken()), [(0.0, 0.0, 0.0, 1.0), (0.01, 0.0, 0.0, 0.9)], tmp_path / "out.csv")
