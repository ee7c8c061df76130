"""Rigid poses (local frame → scene frame) and the number checks shared by the geometry.

A Pose is p_scene = R(quat) p_local + pos with quat = (w, x, y, z). The rotation matrix is built
once at construction; the identity rotation is the fast path almost every scene object takes.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import hypot
from typing import Any

from ..numbers import is_finite_number, is_number
from .vec import Vec3


def _number(value: Any, what: str) -> float:
    if not is_number(value):
        raise ValueError(f"{what} must be a number, got {value!r}")
    if not is_finite_number(value):
        raise ValueError(f"{what} must be finite, got {value!r}")
    return float(value)


def _dimension(value: Any, what: str) -> float:
    v = _number(value, what)
    if v <= 0.0:
        raise ValueError(f"{what} must be > 0, got {value!r}")
    return v


def _floats(value: Any, n: int, what: str, positive: bool = False) -> tuple:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != n:
        raise ValueError(f"{what} must be a list of {n} numbers, got {value!r}")
    conv = _dimension if positive else _number
    return tuple(conv(c, f"{what}[{i}]") for i, c in enumerate(value))


def _plain(t: Any, n: int) -> bool:
    """`t` is already what _floats would make of it: a tuple of n finite floats (the poses a
    scenario builds every tick), so the per-number checks can be skipped. A finite sum means no
    component is NaN or infinite; an overflowing sum only sends a valid pose the slow way."""
    if type(t) is not tuple or len(t) != n:
        return False
    for c in t:
        if type(c) is not float:
            return False
    return 0.0 * sum(t) == 0.0


_NO_ROTATION = (1.0, 0.0, 0.0, 0.0)  # the default quat, recognised by identity (Pose.__post_init__)


@dataclass(frozen=True)
class Pose:
    """Rigid transform local -> scene: p_scene = R(quat) p_local + pos; quat = (w, x, y, z)."""

    pos: Vec3 = (0.0, 0.0, 0.0)
    quat: tuple[float, float, float, float] = _NO_ROTATION

    def __post_init__(self) -> None:
        if self.quat is _NO_ROTATION and _plain(self.pos, 3):
            # A position of plain floats and the default quat (a carried object, every tick):
            # nothing to check, normalise or rotate.
            object.__setattr__(self, "_m", None)
            return
        pos = self.pos if _plain(self.pos, 3) else _floats(self.pos, 3, "pose.pos")
        q = self.quat if _plain(self.quat, 4) else _floats(self.quat, 4, "pose.quat")
        n = hypot(*q)
        if not n > 0.0:
            raise ValueError(f"pose.quat must be non-zero, got {self.quat!r}")
        if abs(n - 1.0) > 1e-12:  # leave unit quats bit-exact so dict round trips are exact
            q = (q[0] / n, q[1] / n, q[2] / n, q[3] / n)
        object.__setattr__(self, "pos", pos)
        object.__setattr__(self, "quat", q)
        w, x, y, z = q
        # Rotation matrix computed once (row-major); None = identity rotation: the fast path used
        # by almost every scene object (only translation per query).
        m = None
        if not (x == 0.0 and y == 0.0 and z == 0.0):
            k = 2.0 / (w * w + x * x + y * y + z * z)  # exact for not-quite-unit quats too
            m = (1 - k * (y * y + z * z), k * (x * y - w * z), k * (x * z + w * y),
                 k * (x * y + w * z), 1 - k * (x * x + z * z), k * (y * z - w * x),
                 k * (x * z - w * y), k * (y * z + w * x), 1 - k * (x * x + y * y))
        object.__setattr__(self, "_m", m)

    def rotate(self, v: Vec3) -> Vec3:
        """Local direction -> scene direction."""
        m = self._m
        if m is None:
            return (v[0], v[1], v[2])
        x, y, z = v
        return (m[0] * x + m[1] * y + m[2] * z, m[3] * x + m[4] * y + m[5] * z,
                m[6] * x + m[7] * y + m[8] * z)

    def unrotate(self, v: Vec3) -> Vec3:
        """Scene direction -> local direction (R transposed)."""
        m = self._m
        if m is None:
            return (v[0], v[1], v[2])
        x, y, z = v
        return (m[0] * x + m[3] * y + m[6] * z, m[1] * x + m[4] * y + m[7] * z,
                m[2] * x + m[5] * y + m[8] * z)

    def to_world(self, p: Vec3) -> Vec3:
        r = self.rotate(p)
        return (r[0] + self.pos[0], r[1] + self.pos[1], r[2] + self.pos[2])

    def to_local(self, p: Vec3) -> Vec3:
        return self.unrotate((p[0] - self.pos[0], p[1] - self.pos[1], p[2] - self.pos[2]))

    def to_dict(self) -> dict:
        return {"pos": list(self.pos), "quat": list(self.quat)}

    @classmethod
    def from_dict(cls, d: Any) -> "Pose":
        """Missing "pos"/"quat" take the defaults (origin, identity)."""
        if not isinstance(d, dict):
            raise ValueError(f"pose must be an object, got {d!r}")
        return cls(d.get("pos", (0.0, 0.0, 0.0)), d.get("quat", (1.0, 0.0, 0.0, 0.0)))
