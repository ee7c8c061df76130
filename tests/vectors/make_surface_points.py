"""Writes tests/vectors/surface_points.json: signed distance, outward normal and closest surface
point of every primitive shape (server/core/haptics/primitives.py, the server's own geometry) at
points inside, outside, on axes, apexes, edges and ties, each shape at an identity, a translated
and a rotated pose. The browser client's copy (clients/web/src/surface_point.js, which draws a
fingertip on the surface before the server's proxy comes back) is tested against it
(clients/web/test/surface_point.test.mjs), and tests/test_surface_points_vector.py fails when
primitives.py changes and this file was not rewritten.

Run: .venv/bin/python tests/vectors/make_surface_points.py
"""

import json
import random
from pathlib import Path

from server.core.haptics.primitives import SHAPE_TYPES, Body, Pose, shape_from_dict

OUT = Path(__file__).parent / "surface_points.json"
SEED = 21
RANDOM_POINTS = 24

SHAPES = [
    {"type": "sphere", "radius": 0.5},
    {"type": "box", "size": [0.6, 0.4, 0.3]},
    {"type": "plane", "size": [3.0, 2.0]},
    {"type": "cylinder", "radius": 0.3, "height": 0.8},
    {"type": "cone", "radius": 0.4, "height": 0.7},
    {"type": "hemisphere", "radius": 0.6},
]
POSES = [
    {"pos": [0.0, 0.0, 0.0], "quat": [1.0, 0.0, 0.0, 0.0]},
    {"pos": [0.25, -0.5, 0.125], "quat": [1.0, 0.0, 0.0, 0.0]},
    {"pos": [-0.3, 0.2, 0.4], "quat": [2.0, 0.5, -1.0, 1.0]},  # |q| = 2.5: normalised as the server does
]


def special_points(shape: dict) -> list:
    """Local points where a choice is made: centres, axes, apexes, edges, faces, below bases."""
    t = shape["type"]
    if t == "sphere":
        return [[0.0, 0.0, 0.0], [0.0, 0.0, 0.25], [0.5, 0.0, 0.0], [0.0, 0.0, -1.0]]
    if t == "box":
        return [[0.0, 0.0, 0.0], [0.3, 0.2, 0.15], [0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.5, 0.5, 0.5],
                [-0.25, 0.0, 0.0], [0.0, 0.0, -0.1]]
    if t == "plane":
        return [[0.0, 0.0, 0.0], [0.0, 0.0, -0.25], [1.5, 1.0, 0.0], [2.0, 0.0, -0.5], [0.0, 0.0, 0.5]]
    if t == "cylinder":
        return [[0.0, 0.0, 0.4], [0.0, 0.0, 0.1], [0.0, 0.0, 1.0], [0.0, 0.0, -0.5], [0.3, 0.0, 0.8],
                [0.5, 0.0, 0.4], [0.25, 0.0, 0.05]]
    if t == "cone":
        return [[0.0, 0.0, 0.7], [0.0, 0.0, 0.9], [0.0, 0.0, 0.1], [0.0, 0.0, -0.2], [0.4, 0.0, 0.0],
                [0.6, 0.0, -0.1], [0.1, 0.0, 0.6], [0.5, 0.0, 0.5]]
    if t == "hemisphere":
        return [[0.0, 0.0, 0.0], [0.0, 0.0, 0.1], [0.0, 0.0, 0.5], [0.0, 0.0, 0.6], [0.0, 0.0, -0.3],
                [0.8, 0.0, -0.2], [0.3, 0.3, 0.3], [0.0, 0.63, 0.0]]
    raise ValueError(f"no special points for {t!r}: add them")


def random_points(rng: random.Random, reach: float) -> list:
    """Points around the shape (inside and out): 6 decimals, so the JSON text is the input."""
    return [[round(rng.uniform(-reach, reach), 6) for _ in range(3)] for _ in range(RANDOM_POINTS)]


def surface_points_data() -> dict:
    rng = random.Random(SEED)
    cases = []
    for sd in SHAPES:
        shape = shape_from_dict(sd)
        for pose_d in POSES:
            pose = Pose.from_dict(pose_d)
            b = Body("b", shape, pose)
            local = special_points(sd) + random_points(rng, 1.0)
            # the special points are local: place them as the pose does, so they stay special
            pts = [list(pose.to_world(p)) for p in local[: len(special_points(sd))]]
            pts += [[v + o for v, o in zip(p, pose.pos)] for p in local[len(special_points(sd)):]]
            rows = []
            for p in pts:
                s, nx, ny, nz = b._eval(p)
                rows.append({"p": p, "sd": s, "normal": [nx, ny, nz], "closest": list(b.closest_point(p))})
            cases.append({"shape": sd, "pose": pose_d, "points": rows})
    return {
        "note": "written by tests/vectors/make_surface_points.py from server/core/haptics/primitives.py",
        "types": sorted(SHAPE_TYPES),
        "cases": cases,
    }


def render() -> str:
    data = surface_points_data()
    head = {k: v for k, v in data.items() if k != "cases"}
    body = ",\n".join(json.dumps(c) for c in data["cases"])
    return json.dumps(head)[:-1] + ', "cases": [\n' + body + "\n]}\n"


if __name__ == "__main__":
    OUT.write_text(render(), encoding="utf-8")
