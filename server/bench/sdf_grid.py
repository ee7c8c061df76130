"""Signed-distance grids sampled from the primitives, as bodies the god-object can touch.

A baseline for `viestac bench accuracy`: many engines touch a voxelised signed distance instead of
the shape. ``GridShape`` samples the exact signed distance of a primitive at the nodes of a regular
grid (``cells`` cells across the shape's largest extent) and interpolates trilinearly; its
normal is the normalised gradient of that interpolant. Error comes from the interpolation
(corners and curvature are rounded off, features thinner than a cell vanish), cost from the
lookups. The interpolant is not convex, so ``GridBody`` replaces the primitives' Newton cast by
sphere tracing (step by the distance, safe while the interpolant is about 1-Lipschitz), finished by
Newton and, after an overshoot, by a bracketed Illinois search so the hit lands ON the surface
as the god-object requires. Outside the grid the distance is the clamped value plus the
distance to the grid box.
"""

from __future__ import annotations

from array import array
from dataclasses import dataclass
from math import sqrt

from server.core.haptics.primitives import (EPS_SURFACE, NEWTON_TOL, SLOPE_TOL, Body, Box, Cone, Cylinder, Hemisphere, Plane,
                         Sphere, _Shape)

CELLS = (16, 32, 64, 128)
PLANE_DEPTH = 0.5  # scene units of solid sampled below a Plane's top face
MAX_TRACE = 200
NEAR = 1e-6  # switch from sphere tracing to Newton this close to the surface


def local_bounds(shape: _Shape) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """Axis-aligned bounds of the solid in its local frame (a Plane: PLANE_DEPTH deep)."""
    if isinstance(shape, Sphere):
        r = shape.radius
        return (-r, -r, -r), (r, r, r)
    if isinstance(shape, Hemisphere):
        r = shape.radius
        return (-r, -r, 0.0), (r, r, r)
    if isinstance(shape, Box):
        h = [0.5 * s for s in shape.size]
        return (-h[0], -h[1], -h[2]), (h[0], h[1], h[2])
    if isinstance(shape, Plane):
        hx, hy = 0.5 * shape.size[0], 0.5 * shape.size[1]
        return (-hx, -hy, -PLANE_DEPTH), (hx, hy, 0.0)
    if isinstance(shape, (Cylinder, Cone)):
        r = shape.radius
        return (-r, -r, 0.0), (r, r, shape.height)
    raise ValueError(f"no bounds for shape {shape!r}")


class GridShape(_Shape):
    """Trilinear signed-distance grid of ``shape``; ``margin`` = free space sampled around it."""

    type = "sdf-grid"

    def __init__(self, shape: _Shape, cells: int, margin: float) -> None:
        if isinstance(cells, bool) or not isinstance(cells, int) or cells < 2:
            raise ValueError(f"cells must be an int >= 2, got {cells!r}")
        lo, hi = local_bounds(shape)
        self.source = f"{shape.type} {cells}"
        self.h = h = max(b - a for a, b in zip(lo, hi)) / cells
        pad = margin + 2.0 * h
        self._o = tuple(a - pad for a in lo)
        self._n = n = tuple(int((b - a + 2.0 * pad) / h) + 2 for a, b in zip(lo, hi))
        self._top = tuple(self._o[k] + (n[k] - 1) * h for k in range(3))
        ev = shape._eval
        ox, oy, oz = self._o
        # x-major, then y, then z (fast): node (i, j, k) at index (i * ny + j) * nz + k; float32
        # storage (6e-8 relative) halves the memory of a 128-cell grid, far below its own error
        self._v = array("f", (ev(ox + i * h, oy + j * h, oz + k * h)[0]
                              for i in range(n[0]) for j in range(n[1]) for k in range(n[2])))
        self.nodes = len(self._v)

    def __repr__(self) -> str:
        return f"GridShape({self.source}, h={self.h:.4g}, {self.nodes} nodes)"

    def to_dict(self) -> dict:
        return {"type": self.type, "source": self.source, "h": self.h, "nodes": self.nodes}

    def _eval(self, x, y, z):
        ox, oy, oz = self._o
        tx, ty, tz = self._top
        out = 0.0
        if not (ox <= x <= tx and oy <= y <= ty and oz <= z <= tz):  # clamp into the grid
            cx, cy, cz = min(max(x, ox), tx), min(max(y, oy), ty), min(max(z, oz), tz)
            out = sqrt((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2)
            if out > 0.0:
                s = self._eval(cx, cy, cz)[0] + out
                return (s, (x - cx) / out, (y - cy) / out, (z - cz) / out)
        h = self.h
        nx, ny, nz = self._n
        fx, fy, fz = (x - ox) / h, (y - oy) / h, (z - oz) / h
        i, j, k = min(int(fx), nx - 2), min(int(fy), ny - 2), min(int(fz), nz - 2)
        u, v, w = fx - i, fy - j, fz - k
        g = self._v
        b = (i * ny + j) * nz + k
        sx, sy = ny * nz, nz
        c000, c001, c010, c011 = g[b], g[b + 1], g[b + sy], g[b + sy + 1]
        c100, c101, c110, c111 = g[b + sx], g[b + sx + 1], g[b + sx + sy], g[b + sx + sy + 1]
        c00 = c000 + (c001 - c000) * w
        c01 = c010 + (c011 - c010) * w
        c10 = c100 + (c101 - c100) * w
        c11 = c110 + (c111 - c110) * w
        c0 = c00 + (c01 - c00) * v
        c1 = c10 + (c11 - c10) * v
        s = c0 + (c1 - c0) * u
        gx = c1 - c0
        gy = (c01 - c00) * (1.0 - u) + (c11 - c10) * u
        d0 = (c001 - c000) * (1.0 - v) + (c011 - c010) * v
        d1 = (c101 - c100) * (1.0 - v) + (c111 - c110) * v
        gz = d0 * (1.0 - u) + d1 * u
        m = sqrt(gx * gx + gy * gy + gz * gz)
        if m == 0.0:
            return (s, 0.0, 0.0, 1.0)
        return (s, gx / m, gy / m, gz / m)


@dataclass(frozen=True)
class GridBody(Body):
    """A Body whose shape is a GridShape, with a cast that does not assume convexity."""

    def _cast(self, a, dx, dy, dz, radius, t_max, ev0, feats=None):
        ev = ev0 if ev0 is not None else self._eval(a)
        f = ev[0] - radius
        if f <= -EPS_SURFACE:
            return (0.0, a, ev)
        length = sqrt(dx * dx + dy * dy + dz * dz)
        if length == 0.0:
            return None
        g = ev[1] * dx + ev[2] * dy + ev[3] * dz
        if f <= EPS_SURFACE:  # on the surface: a hit only when moving inward
            if g < -(SLOPE_TOL * length + NEWTON_TOL):
                return (0.0, a, ev)
            # Sliding along the tangent plane: on a convex body that leaves the surface, but the
            # interpolant is not convex and the slide can end inside it. Then land on the surface
            # below the end point instead (the implicit-surface proxy's projection step,
            # Salisbury & Tarr 1997), so the proxy keeps sliding rather than sticking.
            end = (a[0] + t_max * dx, a[1] + t_max * dy, a[2] + t_max * dz)
            return self._project(end, radius, t_max)
        ax, ay, az = a
        t = 0.0
        for _ in range(MAX_TRACE):
            if f > NEAR or g >= 0.0:
                t_next = t + f / length  # sphere tracing
            else:
                t_next = t - f / g  # Newton, close to the surface
            if t_next > t_max:
                # the last step may overshoot t_max while the surface lies before it
                t_next = t_max
            p = (ax + t_next * dx, ay + t_next * dy, az + t_next * dz)
            ev_next = self._eval(p)
            f_next = ev_next[0] - radius
            if f_next < -NEWTON_TOL:
                return self._bracket(a, dx, dy, dz, radius, t, f, ev, t_next, f_next)
            if f_next <= NEWTON_TOL:
                return (t_next, p, ev_next)
            if t_next >= t_max:
                return None
            t, f, ev = t_next, f_next, ev_next
            g = ev[1] * dx + ev[2] * dy + ev[3] * dz
        return None  # grazing: never closer than NEAR along this segment

    def _project(self, p, radius, t):
        """(t, surface point, eval) below p if p is inside the dilated grid surface, else None."""
        ev = self._eval(p)
        f = ev[0] - radius
        if f >= -NEWTON_TOL:
            return None
        for _ in range(8):  # Newton along the gradient: the interpolant is ~1-Lipschitz
            p = (p[0] - f * ev[1], p[1] - f * ev[2], p[2] - f * ev[3])
            ev = self._eval(p)
            f = ev[0] - radius
            if abs(f) <= NEWTON_TOL:
                break
        return (t, p, ev)

    def _bracket(self, a, dx, dy, dz, radius, t0, f0, ev0, t1, f1):
        """Illinois search on [t0 (outside), t1 (inside)] for the crossing; the result is on the
        surface (|f| <= NEWTON_TOL), or the outside end if the bracket collapses first."""
        side = 0
        for _ in range(100):
            t = t0 - f0 * (t1 - t0) / (f1 - f0)
            p = (a[0] + t * dx, a[1] + t * dy, a[2] + t * dz)
            ev = self._eval(p)
            f = ev[0] - radius
            if abs(f) <= NEWTON_TOL:
                return (t, p, ev)
            if t1 - t0 <= 1e-15:
                break
            if f > 0.0:
                t0, f0, ev0 = t, f, ev
                if side == 1:
                    f1 *= 0.5
                side = 1
            else:
                t1, f1 = t, f
                if side == -1:
                    f0 *= 0.5
                side = -1
        return (t0, (a[0] + t0 * dx, a[1] + t0 * dy, a[2] + t0 * dz), ev0)
