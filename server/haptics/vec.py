"""Tiny 3-vector helpers on plain tuples.

Theory of operation: the 1 kHz haptic loop works on 3-D points and directions only. Small
numpy arrays cost about 5x more per operation than plain Python floats (rendering-notes.md
section 3.1: analytic sphere distance 0.6-0.9 us pure Python vs 3.3-5.5 us with numpy 3-vectors),
so every vector in the per-tick path is a ``tuple[float, float, float]`` and these helpers are
plain functions. Hot loops in primitives.py / god_object.py inline the arithmetic instead of
calling these (a Python call costs ~50-100 ns); the helpers are for clarity elsewhere.

Frame (spec.md): scene frame x toward the viewer, y right, z up, right-handed; units are scene
"metres".
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
