"""Analytic primitives with exact signed distances, rigid poses, bodies and continuous casts.

Theory of operation
-------------------
Every shape lives in its LOCAL frame (docs/protocol.md "Scene format") and implements one kernel,
``_eval(x, y, z) -> (sd, nx, ny, nz)``: the EXACT Euclidean signed distance (negative inside) and
its gradient, the outward unit normal. Everything else derives from it: the closest surface point
is ``p - sd * n`` for inside and outside points alike (the gradient of an exact SDF points away
from the nearest surface point), and ``normal`` is ``n``. Solids of revolution (cylinder, cone,
hemisphere) reduce to an exact 2-D problem in (rho, z), rho = distance from the z axis.

Where the gradient does not exist (sphere centre, points on a rotation axis, cone apex, edges,
equidistant inside points) a deterministic choice is made and documented per shape; points exactly
on an axis are ordinary inputs (a HIP coming straight down the z axis onto a pole or the apex
collides). Ties between faces prefer z (the "up" face), then x, then y.

``Body`` = shape + ``Pose`` (local->scene) + material. ``Body.cast`` is continuous collision
detection against the shape dilated by the proxy radius: phi(t) = sd(a + t(b - a)) - radius is
convex in t for convex shapes (the SDF of a convex set is convex), so Newton's method started at
t = 0 from outside with the exact derivative normal(p).(b - a) approaches the FIRST root from the
left and never overshoots (the tangent of a convex function lies below its graph); iterates stay
outside, flat faces converge in one step. A start ON the surface (|phi| <= EPS_SURFACE) is a hit
only if the one-sided derivative says "inward": for a point proxy that is the max of n.d over
the normals of every face/edge/apex feature the point lies on, so sliding along a face or over
an edge is not a hit (a start slightly outside is finished by Newton, landing exactly on the
surface). This is the segment test of the god-object / virtual proxy (Zilles & Salisbury 1995;
Ruspini et al. 1997) on analytic surfaces. Pure floats, no numpy, no I/O: the 1 kHz loop calls
this many times per tick (numpy 3-vectors cost ~5x, docs/reference.md "Design measurements").
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from math import hypot, sqrt
from typing import Any, ClassVar, Union

from .pose import Pose, _dimension, _floats, _number  # noqa: F401 (Pose re-exported)
from .vec import Vec3

EPS_SURFACE = 1e-10  # |phi| below this = "on the (dilated) surface" (cast start classification)
NEWTON_TOL = 1e-13  # cast converged when phi <= this (the hit point is outside by at most this)
SLOPE_TOL = 1e-12  # moving inward means phi'(0) < -(SLOPE_TOL * |b - a| + NEWTON_TOL): the
# absolute part absorbs rounding in slide targets built on a tangent plane (~1e-16 off it)
FEATURE_TOL = 1e-12  # a face/feature counts as active at a surface point within this distance
APEX_TOL = 1e-9  # points this close to the cone apex use the apex's whole normal cone
MAX_NEWTON = 40


class _Shape:
    """Public local-frame queries, all derived from ``_eval`` (see module docstring)."""

    type: ClassVar[str] = ""

    def __post_init__(self) -> None:
        """Validate (positive, finite) and coerce the dimensions, then precompute constants."""
        for f in fields(self):
            v, what = getattr(self, f.name), f"{self.type} {f.name}"
            if f.name == "size":
                v = _floats(v, 3 if self.type == "box" else 2, what, positive=True)
            else:
                v = _dimension(v, what)
            object.__setattr__(self, f.name, v)
        self._prepare()

    def _prepare(self) -> None:
        pass

    def signed_distance(self, p: Vec3) -> float:
        return self._eval(p[0], p[1], p[2])[0]

    def closest_point(self, p: Vec3) -> Vec3:
        s, nx, ny, nz = self._eval(p[0], p[1], p[2])
        return (p[0] - s * nx, p[1] - s * ny, p[2] - s * nz)

    def normal(self, p: Vec3) -> Vec3:
        return self._eval(p[0], p[1], p[2])[1:]

    def to_dict(self) -> dict:
        d: dict = {"type": self.type}
        for f in fields(self):
            v = getattr(self, f.name)
            d[f.name] = list(v) if isinstance(v, tuple) else v
        return d

    def _eval(self, x: float, y: float, z: float) -> tuple[float, float, float, float]:
        raise NotImplementedError

    def _features(self, x, y, z, dx, dy, dz) -> list:
        """Outward normals of the surface features (faces, dome, side...) a SURFACE point lies
        on; used by radius-0 casts that start on the surface. max(n.d) over them is the one-sided
        derivative of sd along d (support function of the normal cone at an edge), so "moving
        inward" means entering through every adjacent face and sliding over an edge is no hit."""
        return [self._eval(x, y, z)[1:]]


def _radial(x: float, y: float) -> tuple[float, float, float]:
    """rho and the unit radial direction; on the axis (rho == 0) the deterministic choice +x."""
    rho = sqrt(x * x + y * y)
    if rho > 0.0:
        return rho, x / rho, y / rho
    return 0.0, 1.0, 0.0


@dataclass(frozen=True)
class Sphere(_Shape):
    """Ball of ``radius`` centred at the origin. At the centre the normal is +z (closest point
    = the north pole)."""

    radius: float
    type: ClassVar[str] = "sphere"

    def _eval(self, x, y, z):
        r2 = x * x + y * y + z * z
        if r2 > 0.0:
            r = sqrt(r2)
            return (r - self.radius, x / r, y / r, z / r)
        return (-self.radius, 0.0, 0.0, 1.0)


def _box_eval(qx, qy, qz, x, y, z):
    """Box SDF from q = |p| - half extents (Box and Plane); face signs from x, y, z. Inside, the
    nearest face wins, ties prefer z, then x, then y; a coordinate of 0 picks the + face."""
    if qx > 0.0 or qy > 0.0 or qz > 0.0:
        dx = qx if qx > 0.0 else 0.0
        dy = qy if qy > 0.0 else 0.0
        dz = qz if qz > 0.0 else 0.0
        d = sqrt(dx * dx + dy * dy + dz * dz)
        if d > 0.0:  # else: underflow, treat as on the surface (below)
            return (d, (dx if x >= 0.0 else -dx) / d, (dy if y >= 0.0 else -dy) / d,
                    (dz if z >= 0.0 else -dz) / d)
    if qz >= qx and qz >= qy:
        return (qz, 0.0, 0.0, 1.0 if z >= 0.0 else -1.0)
    if qx >= qy:
        return (qx, 1.0 if x >= 0.0 else -1.0, 0.0, 0.0)
    return (qy, 0.0, 1.0 if y >= 0.0 else -1.0, 0.0)


def _box_features(qx, qy, qz, x, y, z) -> list:
    """Normals of the faces whose q is within FEATURE_TOL of the nearest face's."""
    m = max(qx, qy, qz)
    thr = (m if m < 0.0 else 0.0) - FEATURE_TOL
    out = [(1.0 if x >= 0.0 else -1.0, 0.0, 0.0)] if qx >= thr else []
    if qy >= thr:
        out.append((0.0, 1.0 if y >= 0.0 else -1.0, 0.0))
    if qz >= thr:
        out.append((0.0, 0.0, 1.0 if z >= 0.0 else -1.0))
    return out


@dataclass(frozen=True)
class Box(_Shape):
    """Axis-aligned box of edge lengths ``size`` centred at the origin (ties: ``_box_eval``)."""

    size: Vec3
    type: ClassVar[str] = "box"

    def _prepare(self) -> None:
        object.__setattr__(self, "_h", tuple(0.5 * c for c in self.size))

    def _eval(self, x, y, z):
        hx, hy, hz = self._h
        return _box_eval(abs(x) - hx, abs(y) - hy, abs(z) - hz, x, y, z)

    def _features(self, x, y, z, dx, dy, dz):
        hx, hy, hz = self._h
        return _box_features(abs(x) - hx, abs(y) - hy, abs(z) - hz, x, y, z)


@dataclass(frozen=True)
class Plane(_Shape):
    """Finite ground: solid {|x| <= sx/2, |y| <= sy/2, z <= 0}, top face z = 0, semi-infinite
    downward: the box SDF with q = (|x| - sx/2, |y| - sy/2, z). Ties prefer the top face."""

    size: tuple[float, float]
    type: ClassVar[str] = "plane"

    def _prepare(self) -> None:
        object.__setattr__(self, "_h", tuple(0.5 * c for c in self.size))

    def _eval(self, x, y, z):
        hx, hy = self._h
        return _box_eval(abs(x) - hx, abs(y) - hy, z, x, y, 1.0)

    def _features(self, x, y, z, dx, dy, dz):
        hx, hy = self._h
        return _box_features(abs(x) - hx, abs(y) - hy, z, x, y, 1.0)


@dataclass(frozen=True)
class Cylinder(_Shape):
    """Solid cylinder, axis +z, base disc z = 0, top disc z = height. 2-D box SDF in (rho, z)
    with q = (rho - R, |z - h/2| - h/2); inside ties prefer the cap; on the axis the side
    normal is +x."""

    radius: float
    height: float
    type: ClassVar[str] = "cylinder"

    def _prepare(self) -> None:
        object.__setattr__(self, "_hh", 0.5 * self.height)

    def _eval(self, x, y, z):
        rho, ux, uy = _radial(x, y)
        u = rho - self.radius
        zc = z - self._hh
        sz = 1.0 if zc >= 0.0 else -1.0
        w = sz * zc - self._hh
        if u > 0.0 or w > 0.0:
            du = u if u > 0.0 else 0.0
            dw = w if w > 0.0 else 0.0
            d = sqrt(du * du + dw * dw)
            if d > 0.0:
                g = du / d
                return (d, g * ux, g * uy, sz * dw / d)
        if w >= u:
            return (w, 0.0, 0.0, sz)
        return (u, ux, uy, 0.0)

    def _features(self, x, y, z, dx, dy, dz):
        rho, ux, uy = _radial(x, y)
        u = rho - self.radius
        zc = z - self._hh
        sz = 1.0 if zc >= 0.0 else -1.0
        w = sz * zc - self._hh
        m = max(u, w)
        thr = (m if m < 0.0 else 0.0) - FEATURE_TOL
        out = [(0.0, 0.0, sz)] if w >= thr else []
        if u >= thr:
            out.append((ux, uy, 0.0))
        return out


@dataclass(frozen=True)
class Cone(_Shape):
    """Solid cone: base disc of ``radius`` at z = 0, apex at z = height. Exact 2-D distance in
    (rho, z) to the triangle (0,0)-(R,0)-(0,H): base segment, side segment, rim and apex regions.
    At the apex the normal is +z (the axis of its normal cone: a HIP pushing exactly down the
    axis stays on the tip); other axis points use the +x side normal; inside ties prefer the
    base."""

    radius: float
    height: float
    type: ClassVar[str] = "cone"

    def _prepare(self) -> None:
        r, h = self.radius, self.height
        length = hypot(r, h)
        # side outward normal in (rho, z) = (H, R) / L; L2 = squared side length
        object.__setattr__(self, "_k", (length, r * r + h * h, h / length, r / length))

    def _eval(self, x, y, z):
        R = self.radius
        H = self.height
        L, L2, nr, nz = self._k
        rho, ux, uy = _radial(x, y)
        # Signed distance to the side LINE; written so that it is exactly 0 at rim and apex.
        s_line = (H * rho + R * z - R * H) / L
        if z >= 0.0 and s_line <= 0.0:  # inside or on the surface
            if z <= -s_line:
                return (-z, 0.0, 0.0, -1.0)
            if rho == 0.0 and z >= H:
                return (0.0, 0.0, 0.0, 1.0)
            return (s_line, nr * ux, nr * uy, nz)
        if z < 0.0 and rho <= R:  # straight below the base disc
            return (-z, 0.0, 0.0, -1.0)
        sn = (R - rho) * R + z * H  # L * (projection parameter onto the side, from the rim)
        if sn <= 0.0:  # rim region
            dr = rho - R
            dz = z
        elif sn >= L2:  # apex region
            dr = rho
            dz = z - H
        else:  # side region: distance to the line is exact
            return (s_line, nr * ux, nr * uy, nz)
        d = sqrt(dr * dr + dz * dz)
        if d > 0.0:
            return (d, dr / d * ux, dr / d * uy, dz / d)
        return (0.0, nr * ux, nr * uy, nz)

    def _features(self, x, y, z, dx, dy, dz):
        R = self.radius
        H = self.height
        L, _, nr, nz = self._k
        rho, ux, uy = _radial(x, y)
        s_line = (H * rho + R * z - R * H) / L
        m = max(-z, s_line)
        thr = (m if m < 0.0 else 0.0) - FEATURE_TOL
        out = [(0.0, 0.0, -1.0)] if -z >= thr else []
        if s_line >= thr:
            if rho * rho + (z - H) * (z - H) <= APEX_TOL * APEX_TOL:
                # apex: every generator normal (H u, R)/L is a feature; max n.d is attained at
                # u = d_xy/|d_xy|, so that one represents the apex for this direction
                dl = sqrt(dx * dx + dy * dy)
                if dl > 0.0:
                    ux, uy = dx / dl, dy / dl
            out.append((nr * ux, nr * uy, nz))
        return out


@dataclass(frozen=True)
class Hemisphere(_Shape):
    """Sphere of ``radius`` intersected with z >= 0 (dome up, flat base disc at z = 0).
    z < 0: closest point on the base disc ((x, y) clamped radially to R, z = 0); z >= 0 outside
    the sphere: R p/|p|; inside: distance min(R - |p|, z), ties prefer the base."""

    radius: float
    type: ClassVar[str] = "hemisphere"

    def _eval(self, x, y, z):
        R = self.radius
        if z < 0.0:
            rho2 = x * x + y * y
            if rho2 <= R * R:
                return (-z, 0.0, 0.0, -1.0)
            rho = sqrt(rho2)
            dr = rho - R
            d = sqrt(dr * dr + z * z)
            g = dr / (d * rho)
            return (d, g * x, g * y, z / d)
        r = sqrt(x * x + y * y + z * z)
        if r > R or z > R - r:  # outside the ball, or inside but nearer the dome than the base
            return (r - R, x / r, y / r, z / r)
        return (-z, 0.0, 0.0, -1.0)

    def _features(self, x, y, z, dx, dy, dz):
        r = sqrt(x * x + y * y + z * z)
        m = max(r - self.radius, -z)
        thr = (m if m < 0.0 else 0.0) - FEATURE_TOL
        out = [(0.0, 0.0, -1.0)] if -z >= thr else []
        if r - self.radius >= thr and r > 0.0:
            out.append((x / r, y / r, z / r))
        return out


Shape = Union[Sphere, Box, Cylinder, Cone, Plane, Hemisphere]
SHAPE_TYPES: dict[str, type] = {c.type: c for c in (Sphere, Box, Cylinder, Cone, Plane, Hemisphere)}


def shape_from_dict(d: Any) -> Shape:
    """Inverse of ``Shape.to_dict`` (docs/protocol.md "Scene format"); extra keys are ignored."""
    if not isinstance(d, dict):
        raise ValueError(f"shape must be an object, got {d!r}")
    cls = SHAPE_TYPES.get(d.get("type"))  # type: ignore[arg-type]
    if cls is None:
        raise ValueError(f"unknown shape type {d.get('type')!r}; expected one of "
                         f"{sorted(SHAPE_TYPES)}")
    names = [f.name for f in fields(cls)]
    missing = [n for n in names if n not in d]
    if missing:
        raise ValueError(f"{cls.type} shape is missing field(s) {missing}")
    return cls(**{n: d[n] for n in names})


@dataclass(frozen=True)
class Body:
    """A shape placed in the scene with a material. World-space queries transform into the
    shape's local frame (translation only for identity rotations)."""

    id: str
    shape: Shape
    pose: Pose = Pose()
    stiffness_n_per_m: float = 1000.0
    static_friction: float = 0.0
    dynamic_friction: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.id, str) or not self.id:
            raise ValueError(f"body id must be a non-empty string, got {self.id!r}")
        if not isinstance(self.shape, _Shape):
            raise ValueError(f"body {self.id!r}: shape must be a primitive, got {self.shape!r}")
        if not isinstance(self.pose, Pose):
            raise ValueError(f"body {self.id!r}: pose must be a Pose, got {self.pose!r}")
        for name in ("stiffness_n_per_m", "static_friction", "dynamic_friction"):
            v = _number(getattr(self, name), f"body {self.id!r} {name}")
            if v < 0.0:
                raise ValueError(f"body {self.id!r}: {name} must be >= 0, got {v!r}")
            object.__setattr__(self, name, v)
        object.__setattr__(self, "_ev", self.shape._eval)
        object.__setattr__(self, "_o", self.pose.pos)
        object.__setattr__(self, "_m", self.pose._m)

    def _eval(self, p: Vec3) -> tuple[float, float, float, float]:
        """(sd, world normal) at world point p: the per-tick kernel."""
        o = self._o
        x = p[0] - o[0]
        y = p[1] - o[1]
        z = p[2] - o[2]
        m = self._m
        if m is None:
            return self._ev(x, y, z)
        s, a, b, c = self._ev(m[0] * x + m[3] * y + m[6] * z, m[1] * x + m[4] * y + m[7] * z,
                              m[2] * x + m[5] * y + m[8] * z)
        return (s, m[0] * a + m[1] * b + m[2] * c, m[3] * a + m[4] * b + m[5] * c,
                m[6] * a + m[7] * b + m[8] * c)

    def signed_distance(self, p: Vec3) -> float:
        return self._eval(p)[0]

    def closest_point(self, p: Vec3) -> Vec3:
        s, nx, ny, nz = self._eval(p)
        return (p[0] - s * nx, p[1] - s * ny, p[2] - s * nz)

    def normal(self, p: Vec3) -> Vec3:
        return self._eval(p)[1:]

    def cast(self, a: Vec3, b: Vec3, radius: float = 0.0) -> float | None:
        """Smallest t in [0, 1] where a + t(b - a) reaches signed distance ``radius``, or None.
        Starting on the surface counts as a hit only when moving inward (see ``_cast``)."""
        a = (float(a[0]), float(a[1]), float(a[2]))
        hit = self._cast(a, b[0] - a[0], b[1] - a[1], b[2] - a[2], float(radius), 1.0, None)
        return None if hit is None else hit[0]

    def _features(self, a: Vec3, dx: float, dy: float, dz: float) -> list:
        """World normals of the surface features at world point a (see _Shape._features)."""
        o, pose = self._o, self.pose
        if self._m is None:
            return self.shape._features(a[0] - o[0], a[1] - o[1], a[2] - o[2], dx, dy, dz)
        fs = self.shape._features(*pose.to_local(a), *pose.unrotate((dx, dy, dz)))
        return [pose.rotate(n) for n in fs]

    def _cast(self, a, dx, dy, dz, radius, t_max, ev0, feats=None):
        """Newton-from-the-left cast of a + t d, t in [0, t_max]. ev0 = cached _eval(a) or None;
        feats = world feature normals at a to use for a radius-0 start on the surface (the
        god-object passes them with faces glued to other bodies removed), None = all of them.
        Returns (t, point, (sd, normal at the hit)) or None. The returned normal always opposes
        the motion (n.d < 0): it is the constraint plane that stops it."""
        ev = ev0 if ev0 is not None else self._eval(a)
        f = ev[0] - radius
        if f <= -EPS_SURFACE:  # start inside (the god-object pushes out first): stop at once
            return (0.0, a, ev)
        g = ev[1] * dx + ev[2] * dy + ev[3] * dz
        if f <= EPS_SURFACE:
            # On the surface: a hit only if the one-sided derivative says "inward". Tangential
            # motion along a flat face or off a curved convex surface is not a hit.
            thr = -(SLOPE_TOL * sqrt(dx * dx + dy * dy + dz * dz) + NEWTON_TOL)
            if g >= thr and feats is None:
                return None  # max over the features >= n.d for the normal n of one of them
            if radius == 0.0:  # a point proxy can sit on an edge or apex: use every feature
                glued = feats is not None
                if not glued:
                    feats = self._features(a, dx, dy, dz)
                slopes = [n[0] * dx + n[1] * dy + n[2] * dz for n in feats]
                if not slopes or max(slopes) >= thr:
                    return None
                if f <= NEWTON_TOL:
                    if g < 0.0 and (not glued or ev[1:] in feats):
                        return (0.0, a, ev)  # own normal (e.g. +z at the apex) blocks
                    return (0.0, a, (ev[0],) + feats[slopes.index(min(slopes))])
            elif g >= thr:
                return None
            elif f <= NEWTON_TOL:
                return (0.0, a, ev)
            # slightly outside and moving inward: Newton below lands exactly on the surface
        ax, ay, az = a
        t = 0.0
        p = a
        for _ in range(MAX_NEWTON):
            if g >= 0.0:  # convex phi > 0 and not decreasing: no root ahead
                return None
            t -= f / g
            if t > t_max:
                return None
            p = (ax + t * dx, ay + t * dy, az + t * dz)
            prev = ev
            ev = self._eval(p)
            f = ev[0] - radius
            if f <= NEWTON_TOL:
                if ev[1] * dx + ev[2] * dy + ev[3] * dz >= 0.0:
                    # landed exactly on an edge whose tie-break normal does not oppose the
                    # motion: use the gradient of the approach side (last outside iterate)
                    ev = (ev[0],) + prev[1:]
                return (t, p, ev)
            g = ev[1] * dx + ev[2] * dy + ev[3] * dz
        return (t, p, ev)  # cap (grazing double root): stop just outside, never inside
