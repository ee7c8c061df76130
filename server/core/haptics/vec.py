"""Tiny 3-vector helpers on plain tuples.

Theory of operation: the 1 kHz haptic loop works on 3-D points and directions only. Small
numpy arrays cost about 5x more per operation than plain Python floats (docs/reference.md
"Design measurements": sphere distance 0.6-0.9 us pure Python, 3.3-5.5 us with numpy 3-vectors),
so every vector in the per-tick path is a ``tuple[float, float, float]`` and these helpers are
plain functions. Hot loops in primitives.py / god_object.py inline the arithmetic instead of
calling these (a Python call costs ~50-100 ns); the helpers are for clarity elsewhere.

Frame (docs/reference.md "Frame and units"): scene frame x toward the viewer, y right, z up,
right-handed; units are scene "metres".
"""

from __future__ import annotations

from math import sqrt

Vec3 = tuple[float, float, float]

# Deterministic fallback direction for normalising a zero vector: "up" (+z), the outward normal of
# the ground and the most common contact direction in the ViESTac scenes.
ZERO_DIRECTION: Vec3 = (0.0, 0.0, 1.0)


def add(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def sub(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def scale(a: Vec3, s: float) -> Vec3:
    return (a[0] * s, a[1] * s, a[2] * s)


def dot(a: Vec3, b: Vec3) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a: Vec3, b: Vec3) -> Vec3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def norm(a: Vec3) -> float:
    return sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


def normalize(a: Vec3) -> Vec3:
    """Unit vector along ``a``; for the zero vector (or one whose squared norm underflows to 0)
    returns ZERO_DIRECTION = (0, 0, 1) so callers never divide by zero. Non-finite input gives
    non-finite output."""
    n = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
    if n == 0.0:
        return ZERO_DIRECTION
    return (a[0] / n, a[1] / n, a[2] / n)


def lerp(a: Vec3, b: Vec3, t: float) -> Vec3:
    """a + t (b - a); t = 0 gives a, t = 1 gives b (up to rounding)."""
    return (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2]))


def dist(a: Vec3, b: Vec3) -> float:
    dx = a[0] - b[0]
    dy = a[1] - b[1]
    dz = a[2] - b[2]
    return sqrt(dx * dx + dy * dy + dz * dz)


# --- projection onto an intersection of half-spaces (the god-object's slide sub-goal) --------

HalfSpace = tuple[float, float, float, float]  # (nx, ny, nz, c): {p : n.p >= c}, |n| = 1
FEAS_TOL = 1e-12  # slack of the constraints when testing a candidate's feasibility
PARALLEL_TOL = 1e-10  # 1 - (n_i.n_j)^2 below this (angle < ~1e-5 rad): pair skipped
TRIPLE_TOL = 1e-8  # |n1.(n2 x n3)| below this: triple skipped


def project_halfspaces(h: Vec3, planes: list[HalfSpace]) -> Vec3 | None:
    """argmin |t - h| s.t. n_i.t >= c_i, by enumerating the closed-form active-set candidates: h
    itself, its projection onto one plane, onto the line of two, the point of three; the
    feasible candidate nearest h wins. The true minimiser is the projection of h onto the affine
    hull of its active constraints (at most 3 independent ones in 3-D, Zilles & Salisbury 1995),
    so it is among the candidates. Closed form costs ~1 us where a numpy KKT solve costs ~25 us
    (docs/reference.md "Design measurements"). Near-parallel pairs and degenerate triples are
    skipped; None if no candidate is feasible."""
    hx, hy, hz = h
    if len(planes) == 1:  # the common case
        nx, ny, nz, c = planes[0]
        s = nx * hx + ny * hy + nz * hz - c
        return h if s >= 0.0 else (hx - s * nx, hy - s * ny, hz - s * nz)
    viol = [nx * hx + ny * hy + nz * hz - c for nx, ny, nz, c in planes]
    if min(viol) >= -FEAS_TOL:
        return h

    def feasible(t):
        return all(nx * t[0] + ny * t[1] + nz * t[2] - c >= -FEAS_TOL for nx, ny, nz, c in planes)

    best, best_d2, m = None, float("inf"), len(planes)
    for i in range(m):
        s = viol[i]
        nx, ny, nz, _ = planes[i]
        if s < 0.0 and s * s < best_d2 and feasible(t := (hx - s * nx, hy - s * ny, hz - s * nz)):
            best, best_d2 = t, s * s
        for j in range(i + 1, m):
            bx, by, bz, _ = planes[j]
            g = nx * bx + ny * by + nz * bz
            det = 1.0 - g * g
            if det < PARALLEL_TOL:
                continue
            p = (viol[i] - g * viol[j]) / det  # t = h - p n_i - q n_j lies on both planes
            q = (viol[j] - g * viol[i]) / det
            ox, oy, oz = p * nx + q * bx, p * ny + q * by, p * nz + q * bz
            d2 = ox * ox + oy * oy + oz * oz
            if d2 < best_d2 and feasible(t := (hx - ox, hy - oy, hz - oz)):
                best, best_d2 = t, d2
            for k in range(j + 1, m):
                t = _three_planes(planes[i], planes[j], planes[k])
                if t is not None and (d2 := _dist2(t, h)) < best_d2 and feasible(t):
                    best, best_d2 = t, d2
    return best


def _dist2(a: Vec3, b: Vec3) -> float:
    dx, dy, dz = a[0] - b[0], a[1] - b[1], a[2] - b[2]
    return dx * dx + dy * dy + dz * dz  # products, not ** 2: no OverflowError for huge values


def _three_planes(p1: HalfSpace, p2: HalfSpace, p3: HalfSpace) -> Vec3 | None:
    """Point where three planes n.t = c meet (Cramer's rule), None if near-degenerate."""
    n1, n2, n3 = p1[:3], p2[:3], p3[:3]
    u, v, w = cross(n2, n3), cross(n3, n1), cross(n1, n2)
    det = dot(n1, u)
    if abs(det) < TRIPLE_TOL:
        return None
    return scale(add(add(scale(u, p1[3]), scale(v, p2[3])), scale(w, p3[3])), 1.0 / det)
