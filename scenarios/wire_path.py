"""The hot wire's path (thesis §4.2.4): a polyline of segments, a circle or
a spiral (both made of segments), and the one query the task needs: the nearest projection of a
point on the path (distance and arc position).

Pure geometry on numpy arrays; a projection over a few hundred segments costs tens of
microseconds (docs/performance.md), well inside a 1 ms tick. numpy is imported where a path is
built or queried, not with the module: the loop process imports every scenario at start-up, and
numpy alone was a third of that (0.34 of 1.15 s, `python -X importtime`), for a scenario that
may never run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from server.core.scene import Mesh

PATH_KINDS = ("segments", "circle", "spiral")
MAX_POINTS = 500


@dataclass(frozen=True)
class Projection:
    distance: float                       # from the point to its nearest projection on the path
    arc: float                            # arc length from the start to that projection
    point: tuple[float, float, float]     # the projection


class Path:
    """A polyline from its first point (the start) to its last (the target)."""

    def __init__(self, points) -> None:
        import numpy as np

        pts = np.asarray(points, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 3 or not 2 <= len(pts) <= MAX_POINTS:
            raise ValueError(f"a path needs 2..{MAX_POINTS} points of 3 coordinates")
        if not np.isfinite(pts).all():
            raise ValueError("path points must be finite")
        seg = pts[1:] - pts[:-1]
        lengths = np.linalg.norm(seg, axis=1)
        if (lengths < 1e-9).any():
            raise ValueError(f"path point {int(np.argmax(lengths < 1e-9)) + 1} repeats the one before it")
        self.points = pts
        self._a, self._seg, self._len2 = pts[:-1], seg, lengths ** 2
        self._arc0 = np.concatenate(([0.0], np.cumsum(lengths)))  # arc length at each point
        self.length = float(self._arc0[-1])

    @property
    def start(self) -> tuple[float, float, float]:
        return tuple(map(float, self.points[0]))

    @property
    def end(self) -> tuple[float, float, float]:
        return tuple(map(float, self.points[-1]))

    def project(self, p) -> Projection:
        """The nearest projection of `p` on the path (the least distance over all segments)."""
        import numpy as np  # loaded already (the path was built): a dictionary lookup
        d = np.asarray(p, dtype=float) - self._a
        t = np.clip(np.einsum("ij,ij->i", d, self._seg) / self._len2, 0.0, 1.0)
        offset = d - t[:, None] * self._seg
        dist2 = np.einsum("ij,ij->i", offset, offset)
        i = int(np.argmin(dist2))
        point = self._a[i] + t[i] * self._seg[i]
        arc = self._arc0[i] + t[i] * math.sqrt(self._len2[i])
        return Projection(math.sqrt(float(dist2[i])), float(arc), tuple(map(float, point)))

    def point_at(self, arc: float) -> tuple[float, float, float]:
        """The point `arc` along the path from its start (clamped to the path)."""
        import numpy as np
        if arc >= self.length:
            return self.end
        arc = max(arc, 0.0)
        i = min(int(np.searchsorted(self._arc0, arc, side="right")) - 1, len(self._a) - 1)
        t = (arc - self._arc0[i]) / math.sqrt(self._len2[i])
        return tuple(map(float, self._a[i] + t * self._seg[i]))

    def mesh(self, radius: float = 0.015, sections: int = 6) -> Mesh:
        """The path drawn as a thin tube: one trimesh cylinder per segment (display only)."""
        import trimesh  # here, not at import: the loop process starts 0.4 s sooner without it
        parts = [trimesh.creation.cylinder(radius, sections=sections, segment=(a, b))
                 for a, b in zip(self.points[:-1], self.points[1:])]
        joined = trimesh.util.concatenate(parts)
        return Mesh(tuple(tuple(round(float(c), 5) for c in v) for v in joined.vertices),
                    tuple(tuple(int(i) for i in f) for f in joined.faces))


# -- the three path kinds (defaults: they fit the 3 × 4 table with a margin) --------------------

def segments_points(height: float) -> list[tuple[float, float, float]]:
    """A zigzag across the table, left to right."""
    return [(0.0, -1.6, height), (0.6, -1.0, height), (-0.5, -0.4, height), (0.5, 0.3, height),
            (-0.4, 0.9, height), (0.2, 1.6, height)]


def circle_points(height: float, radius: float = 1.0, gap_deg: float = 30.0,
                  n: int = 72) -> list[tuple[float, float, float]]:
    """A circle round the table's centre, left open by `gap_deg` so start and target differ."""
    span = math.radians(360.0 - gap_deg)
    start = -math.pi / 2 + math.radians(gap_deg) / 2  # the gap at the back, away from the viewer
    return [(radius * math.sin(start + span * k / n), radius * math.cos(start + span * k / n), height)
            for k in range(n + 1)]


def spiral_points(height: float, r_outer: float = 1.2, r_inner: float = 0.25, turns: float = 2.0,
                  per_turn: int = 60) -> list[tuple[float, float, float]]:
    """An Archimedean spiral from the outside in (start outside, target near the centre)."""
    n = int(turns * per_turn)
    out = []
    for k in range(n + 1):
        f = k / n
        r, a = r_outer + (r_inner - r_outer) * f, 2 * math.pi * turns * f
        out.append((r * math.sin(a), -r * math.cos(a), height))
    return out


def parse_points(text: str) -> list[tuple[float, float, float]]:
    """Points written as "x y z; x y z; ..." (or with commas), scene units."""
    points = []
    for k, chunk in enumerate(filter(None, (c.strip() for c in text.split(";"))), start=1):
        parts = chunk.replace(",", " ").split()
        try:
            xyz = tuple(float(v) for v in parts)
        except ValueError:
            raise ValueError(f"path point {k} ({chunk!r}) is not three numbers") from None
        if len(xyz) != 3:
            raise ValueError(f"path point {k} ({chunk!r}) needs 3 coordinates, has {len(xyz)}")
        points.append(xyz)
    return points


def make_path(kind: str, height: float, points: str | None = None) -> Path:
    """The path of `kind`; for "segments", `points` (text) replaces the default zigzag."""
    if kind not in PATH_KINDS:
        raise ValueError(f"path must be one of {', '.join(PATH_KINDS)}, got {kind!r}")
    if points and kind != "segments":
        raise ValueError("points only apply to path 'segments'")
    if kind == "segments":
        return Path(parse_points(points) if points else segments_points(height))
    return Path(circle_points(height) if kind == "circle" else spiral_points(height))
