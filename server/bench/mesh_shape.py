"""Triangle-mesh tessellations of the primitives, as a shape the god-object can touch.

A baseline for `viestac bench accuracy`: the server touches exact primitives, and this shows what a
mesh would cost and how far its surface lies from the true one. A ``MeshShape`` is the convex
polyhedron of a tessellation (trimesh makes the triangles, the convex hull orients them). Its
signed distance is exact for that polyhedron: inside, the distance to the nearest face plane
(for a convex polyhedron that is the distance to the boundary); outside, the closest point over
the faces in front of the point (only those can hold it), found with numpy after an axis-aligned
box bound prunes the faces that cannot beat the nearest face centroid. The polyhedron is
convex, so the primitives' Newton cast (``Body._cast``) stays exact and continuous on it.
"""

from __future__ import annotations

from math import sqrt

import numpy as np
import trimesh

from server.core.haptics.primitives import FEATURE_TOL, Box, Cone, Cylinder, Hemisphere, Plane, Sphere, _Shape

LEVELS = (1, 2, 3, 4)  # icosphere subdivisions; round shapes get 4 * 2**level sections


def tessellate(shape: _Shape, level: int) -> trimesh.Trimesh:
    """A convex triangle mesh of ``shape`` in its local frame; finer with ``level`` (1..4).
    A Plane (solid below z = 0) becomes a box as deep as it is wide, top face at z = 0."""
    if level not in LEVELS:
        raise ValueError(f"tessellation level must be one of {LEVELS}, got {level!r}")
    sections = 4 * 2 ** level
    if isinstance(shape, Sphere):
        mesh = trimesh.creation.icosphere(subdivisions=level, radius=shape.radius)
    elif isinstance(shape, Hemisphere):
        ball = trimesh.creation.icosphere(subdivisions=level, radius=shape.radius)
        top = ball.vertices[ball.vertices[:, 2] > 1e-9]
        a = np.linspace(0.0, 2.0 * np.pi, 4 * sections, endpoint=False)
        rim = np.column_stack([shape.radius * np.cos(a), shape.radius * np.sin(a), np.zeros_like(a)])
        mesh = trimesh.Trimesh(np.vstack([top, rim]))
    elif isinstance(shape, Box):
        mesh = trimesh.creation.box(extents=shape.size)
    elif isinstance(shape, Plane):
        depth = max(shape.size)
        mesh = trimesh.creation.box(extents=(*shape.size, depth))
        mesh.apply_translation((0.0, 0.0, -0.5 * depth))
    elif isinstance(shape, Cylinder):
        mesh = trimesh.creation.cylinder(radius=shape.radius, height=shape.height, sections=sections)
        mesh.apply_translation((0.0, 0.0, 0.5 * shape.height))
    elif isinstance(shape, Cone):
        mesh = trimesh.creation.cone(radius=shape.radius, height=shape.height, sections=sections)
    else:
        raise ValueError(f"no tessellation for shape {shape!r}")
    return mesh.convex_hull  # consistent outward winding, and the convexity the cast relies on


class MeshShape(_Shape):
    """The convex polyhedron of a triangle mesh (vertices in the shape's local frame)."""

    type = "mesh"

    def __init__(self, mesh: trimesh.Trimesh, source: str = "") -> None:
        if not mesh.is_convex:
            raise ValueError("MeshShape needs a convex mesh (its cast assumes a convex signed distance)")
        tri = np.asarray(mesh.triangles, dtype=float)
        self.source = source
        self.faces = len(tri)
        self._a = tri[:, 0]
        self._n = np.asarray(mesh.face_normals, dtype=float)
        self._d = (self._n * self._a).sum(axis=1)  # plane offsets: n . x = d
        # the three edges stacked (3, faces, 3): starts, vectors, squared lengths and the
        # in-plane normals n x e pointing into the triangle (p is over the triangle iff
        # (p - start) . (n x e) >= 0 for all three edges)
        self._start = np.stack([tri[:, 0], tri[:, 1], tri[:, 2]])
        self._edge = np.stack([tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 1], tri[:, 0] - tri[:, 2]])
        self._edge2 = (self._edge * self._edge).sum(axis=2)
        self._inward = np.cross(self._n[None, :, :], self._edge)
        self._lo, self._hi = tri.min(axis=1), tri.max(axis=1)
        self._centroid = tri.mean(axis=1)

    @classmethod
    def of(cls, shape: _Shape, level: int) -> "MeshShape":
        return cls(tessellate(shape, level), f"{shape.type} L{level}")

    def __repr__(self) -> str:
        return f"MeshShape({self.source or '?'}, {self.faces} triangles)"

    def to_dict(self) -> dict:
        return {"type": self.type, "source": self.source, "faces": self.faces}

    def _closest(self, p: np.ndarray, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Closest points on faces ``idx`` to p, and their squared distances."""
        rel = p - self._start[:, idx]  # (3, k, 3): p relative to each edge's start
        over = ((rel * self._inward[:, idx]).sum(axis=2) >= 0.0).all(axis=0)  # p over the triangle
        edge = self._edge[:, idx]
        t = np.clip((rel * edge).sum(axis=2) / self._edge2[:, idx], 0.0, 1.0)
        off = rel - t[:, :, None] * edge  # p minus the closest point on each edge
        d2 = (off * off).sum(axis=2)
        e = d2.argmin(axis=0)
        k = np.arange(len(idx))
        best = p - off[e, k]
        best_d2 = d2[e, k]
        if over.any():
            n = self._n[idx[over]]
            h = (rel[0, over] * n).sum(axis=1)
            best[over] = p - h[:, None] * n
            best_d2[over] = h * h
        return best, best_d2

    def _eval(self, x, y, z):
        p = np.array((x, y, z))
        s = self._n @ p - self._d
        i = int(np.argmax(s))
        if s[i] <= 0.0:  # inside (or on): the nearest face plane
            n = self._n[i]
            return (float(s[i]), float(n[0]), float(n[1]), float(n[2]))
        front = np.flatnonzero(s > 0.0)
        # prune: a face whose bounding box is farther than the nearest face centroid cannot win
        if len(front) > 16:
            to_c = self._centroid[front] - p
            ub2 = float((to_c * to_c).sum(axis=1).min())
            gap = np.maximum(np.maximum(self._lo[front] - p, p - self._hi[front]), 0.0)
            front = front[(gap * gap).sum(axis=1) <= ub2]
        c, d2 = self._closest(p, front)
        j = int(np.argmin(d2))
        d = sqrt(float(d2[j]))
        if d == 0.0:
            n = self._n[front[j]]
            return (0.0, float(n[0]), float(n[1]), float(n[2]))
        v = (p - c[j]) / d
        return (d, float(v[0]), float(v[1]), float(v[2]))

    def _features(self, x, y, z, dx, dy, dz) -> list:
        """Normals of the faces within FEATURE_TOL of a surface point (an edge or vertex of the
        polyhedron lies on several)."""
        p = np.array((x, y, z))
        s = self._n @ p - self._d
        near = np.flatnonzero(np.abs(s) <= FEATURE_TOL)
        if len(near) == 0:
            return [self._eval(x, y, z)[1:]]
        _, d2 = self._closest(p, near)
        keep = near[d2 <= FEATURE_TOL * FEATURE_TOL]
        out: list = []
        for n in self._n[keep] if len(keep) else self._n[near[[int(np.argmin(d2))]]]:
            t = (float(n[0]), float(n[1]), float(n[2]))
            if t not in out:
                out.append(t)
        return out
