"""Fixed HIP trajectories over the thesis scenes, each tick paired with its analytic truth.

The truth is the proxy position of the frictionless god-object model, in closed form from the
geometry that built the path (never from the code under test):

* over a smooth patch (dome, sphere, plane, box top, cylinder side, cone side) the HIP is
  ``s + (r - depth) n`` for a surface point s with outward normal n, so the proxy is ``s + r n``;
* a deep press into a box or cylinder top near its side keeps the proxy on the top face (the
  god-object remembers where it entered; a nearest-face rule jumps to the side);
* a descent into the crease where a sphere or dome meets the ground: the radial projection onto
  the dilated sphere while that lies above the dilated ground, else the crease point.

``None`` as truth means "free": the HIP is outside every dilated body. Time is one sample per
1 kHz tick; speeds are in scene units per second (scene units are CHAI3D's "metres").
"""

from __future__ import annotations

from dataclasses import dataclass
from math import cos, pi, radians, sin, sqrt
from typing import Callable, Optional

from server.core.haptics.vec import Vec3

TICK_S = 0.001
LIFT = 0.05  # approach from / lift to this far outside the dilated surface
STROKE_DEPTH = 0.01
Truth = Optional[Vec3]
Surface = Callable[[float], tuple[Vec3, Vec3]]  # u -> (surface point, outward normal)


@dataclass(frozen=True)
class Trajectory:
    scene: str
    hips: tuple[Vec3, ...]
    truths: tuple[Truth, ...]
    segments: tuple[tuple[str, int], ...]  # (what, ticks)


class _Builder:
    def __init__(self, radius: float, speed_scale: float) -> None:
        self.r = radius
        self.k = speed_scale
        self.hips: list[Vec3] = []
        self.truths: list[Truth] = []
        self.segments: list[tuple[str, int]] = []

    def _add(self, what: str, samples: list[tuple[Vec3, Truth]]) -> None:
        for hip, truth in samples:
            self.hips.append(hip)
            self.truths.append(truth)
        self.segments.append((what, len(samples)))

    def _steps(self, length: float, speed: float) -> int:
        return max(2, int(length / (speed * self.k * TICK_S)) + 1)

    def stroke(self, what: str, surface: Surface, u0: float, u1: float, speed: float,
               depth: Callable[[float], float] = lambda u: STROKE_DEPTH) -> None:
        """Follow surface(u), u0 -> u1, at ``speed`` along the surface, ``depth(u)`` inside."""
        dense = [surface(u0 + (u1 - u0) * i / 400) for i in range(401)]
        length = sum(_dist(dense[i][0], dense[i + 1][0]) for i in range(400))
        n = self._steps(length, speed)
        out = []
        for i in range(n):
            u = u0 + (u1 - u0) * i / (n - 1)
            s, nrm = surface(u)
            out.append((_along(s, nrm, self.r - depth(u)), _along(s, nrm, self.r)))
        self._add(what, out)

    def normal_move(self, what: str, surface: Surface, u: float, d0: float, d1: float, speed: float) -> None:
        """Along the normal at surface(u) from depth d0 to d1 (negative depth = outside)."""
        s, nrm = surface(u)
        n = self._steps(abs(d1 - d0), speed)
        out = []
        for i in range(n):
            d = d0 + (d1 - d0) * i / (n - 1)
            out.append((_along(s, nrm, self.r - d), _along(s, nrm, self.r) if d > 0.0 else None))
        self._add(what, out)

    def touch(self, what: str, surface: Surface, u: float, depth: float, speed: float) -> None:
        self.normal_move(f"{what}: approach", surface, u, -LIFT, depth, speed)

    def lift(self, what: str, surface: Surface, u: float, depth: float, speed: float) -> None:
        self.normal_move(f"{what}: lift", surface, u, depth, -LIFT, speed)

    def explore(self, what: str, how: str, surface: Surface, u0: float, u1: float) -> None:
        """Touch down at u0, stroke to u1 STROKE_DEPTH deep, lift off."""
        self.touch(what, surface, u0, STROKE_DEPTH, APPROACH)
        self.stroke(f"{what}: {how}", surface, u0, u1, STROKE)
        self.lift(what, surface, u1, STROKE_DEPTH, APPROACH)

    def line(self, what: str, a: Vec3, b: Vec3, speed: float, truth: Callable[[Vec3], Truth]) -> None:
        n = self._steps(_dist(a, b), speed)
        out = []
        for i in range(n):
            t = i / (n - 1)
            hip = (a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t)
            out.append((hip, truth(hip)))
        self._add(what, out)

    def top_press(self, what: str, xy: tuple[float, float], top: float, depth: float, speed: float) -> None:
        """Straight down onto a flat top face at xy (inside its footprint), ``depth`` below the
        dilated top and back up: the proxy stays on the top face."""
        r = self.r
        above = (xy[0], xy[1], top + r + LIFT)
        below = (xy[0], xy[1], top + r - depth)

        def truth(hip: Vec3) -> Truth:
            return (hip[0], hip[1], top + r) if hip[2] < top + r else None

        self.line(f"{what}: press", above, below, speed, truth)
        self.line(f"{what}: release", below, above, speed, truth)

    def crease(self, what: str, centre: Vec3, radius: float, azimuth_deg: float, speed: float) -> None:
        """Down a vertical line just inside the circle where the dilated sphere (or dome) meets
        the dilated ground (top z = 0), to below the ground's dilated top, and back up."""
        r, (cx, cy, h) = self.r, centre
        big = radius + r
        rho_c = sqrt(big * big - (r - h) ** 2)
        ca, sa = cos(radians(azimuth_deg)), sin(radians(azimuth_deg))
        rho = rho_c - 0.01
        corner = (cx + rho_c * ca, cy + rho_c * sa, r)

        def truth(hip: Vec3) -> Truth:
            v = (hip[0] - cx, hip[1] - cy, hip[2] - h)
            d = sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
            if d < big:  # inside the dilated sphere: its radial projection, unless under the ground
                a = (cx + big * v[0] / d, cy + big * v[1] / d, h + big * v[2] / d)
                return a if a[2] >= r else corner
            if hip[2] >= r:
                return None
            # under the dilated ground: straight up onto it, unless that is inside the sphere
            # (below a ball's equator the line leaves the ball under the ground)
            up = (hip[0] - cx, hip[1] - cy, r - h)
            return (hip[0], hip[1], r) if up[0] ** 2 + up[1] ** 2 + up[2] ** 2 >= big * big else corner

        top = h + sqrt(big * big - rho * rho) + LIFT
        a = (cx + rho * ca, cy + rho * sa, top)
        b = (cx + rho * ca, cy + rho * sa, r - 0.05)
        self.line(f"{what}: into the crease", a, b, speed, truth)
        self.line(f"{what}: out of the crease", b, a, speed, truth)

    def build(self, scene: str) -> Trajectory:
        return Trajectory(scene, tuple(self.hips), tuple(self.truths), tuple(self.segments))


def _along(s: Vec3, n: Vec3, d: float) -> Vec3:
    return (s[0] + d * n[0], s[1] + d * n[1], s[2] + d * n[2])


def _dist(a: Vec3, b: Vec3) -> float:
    return sqrt((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2)


def sphere_arc(centre: Vec3, radius: float, azimuth_deg: float) -> Surface:
    """u = polar angle (degrees from +z) in the vertical plane at ``azimuth_deg``."""
    ca, sa = cos(radians(azimuth_deg)), sin(radians(azimuth_deg))

    def at(u: float) -> tuple[Vec3, Vec3]:
        t = radians(u)
        n = (sin(t) * ca, sin(t) * sa, cos(t))
        return _along(centre, n, radius), n
    return at


def flat(z: float, start: tuple[float, float], direction: tuple[float, float]) -> Surface:
    """u = distance along ``direction`` from ``start`` on the plane z (normal +z)."""
    def at(u: float) -> tuple[Vec3, Vec3]:
        return (start[0] + u * direction[0], start[1] + u * direction[1], z), (0.0, 0.0, 1.0)
    return at


def cylinder_ring(base: Vec3, radius: float, z: float) -> Surface:
    """u = azimuth (degrees) around a vertical cylinder's side at height z above its base."""
    def at(u: float) -> tuple[Vec3, Vec3]:
        a = radians(u)
        n = (cos(a), sin(a), 0.0)
        return (base[0] + radius * n[0], base[1] + radius * n[1], base[2] + z), n
    return at


def cone_ring(base: Vec3, radius: float, height: float, z: float) -> Surface:
    """u = azimuth (degrees) around a cone's side at height z above its base."""
    rho = radius * (1.0 - z / height)
    length = sqrt(radius * radius + height * height)

    def at(u: float) -> tuple[Vec3, Vec3]:
        a = radians(u)
        n = (height * cos(a) / length, height * sin(a) / length, radius / length)
        return (base[0] + rho * cos(a), base[1] + rho * sin(a), base[2] + z), n
    return at


STROKE = 0.3  # scene units per second: exploring a surface
PRESS = 0.1  # pressing into it
FAST = 2.0  # a quick flick across it
APPROACH = 0.2


def scene_trajectory(scene: str, radius: float, speed_scale: float = 1.0) -> Trajectory:
    """The fixed trajectory of a thesis scene (geometry from the scenario's own scene)."""
    b = _Builder(radius, speed_scale)
    if scene == "contact-angle-v1":  # the dome (R 0.6 at the origin) on the ground
        dome = sphere_arc((0.0, 0.0, 0.0), 0.6, 90.0)
        b.touch("dome", dome, -60, STROKE_DEPTH, APPROACH)
        b.stroke("dome: stroke over the top", dome, -60, 60, STROKE)
        b.normal_move("dome: press", dome, 60, STROKE_DEPTH, 0.04, PRESS)
        b.normal_move("dome: release", dome, 60, 0.04, STROKE_DEPTH, PRESS)
        b.stroke("dome: fast stroke back", dome, 60, -60, FAST)
        b.lift("dome", dome, -60, STROKE_DEPTH, APPROACH)
        b.crease("dome", (0.0, 0.0, 0.0), 0.6, 45.0, APPROACH)
    elif scene == "texture-v1":  # the texture plane, top z = 0
        plane = flat(0.0, (-0.5, 0.0), (1.0, 0.0))
        b.touch("plane", plane, 0.0, STROKE_DEPTH, APPROACH)
        b.stroke("plane: stroke with varying depth", plane, 0.0, 1.0, STROKE,
                 depth=lambda u: STROKE_DEPTH * (1.0 - cos(2 * pi * 3 * u)) + 1e-3)
        b.lift("plane", plane, 1.0, 1e-3, APPROACH)
    elif scene == "stiffness-v1":  # the middle sphere (R 0.4 at height 0.4) on the ground
        centre = (0.0, 0.0, 0.4)
        sphere = sphere_arc(centre, 0.4, 0.0)
        b.touch("sphere", sphere, 0, STROKE_DEPTH, APPROACH)
        for _ in range(2):
            b.normal_move("sphere: probe", sphere, 0, STROKE_DEPTH, 0.03, PRESS)
            b.normal_move("sphere: release", sphere, 0, 0.03, STROKE_DEPTH, PRESS)
        b.stroke("sphere: stroke down the side", sphere, 0, 60, STROKE)
        b.lift("sphere", sphere, 60, STROKE_DEPTH, APPROACH)
        b.crease("sphere", centre, 0.4, 0.0, APPROACH)
    elif scene == "shape-v1":  # cube (edge 1, top 1.0) at y -1.5, sphere R 0.5 at y 0, cone at y 1.5
        top = flat(1.0, (0.0, -1.5), (1.0, 0.0))
        b.explore("cube top", "stroke toward the edge", top, 0.0, 0.4)
        b.top_press("cube top 5 cm from the edge, 9 cm deep", (0.45, -1.5), 1.0, 0.15, PRESS)
        centre = (0.0, 0.0, 0.5)
        sphere = sphere_arc(centre, 0.5, 0.0)
        b.explore("sphere", "stroke over the top", sphere, -50, 50)
        b.crease("sphere", centre, 0.5, 180.0, APPROACH)
        cone = cone_ring((0.0, 1.5, 0.0), 0.5, 1.0, 0.5)
        b.explore("cone side", "half way round", cone, 0, 180)
    elif scene == "positioning-v1":  # cube_a (edge 0.3), the round hole's rim, the small sphere
        top = flat(0.3, (-0.8, 1.8), (1.0, 0.0))
        b.explore("cube top", "stroke toward the edge", top, 0.0, 0.1)
        b.top_press("cube top 3 cm from the edge, 6 cm deep", (-0.8 + 0.12, 1.8), 0.3, 0.12, PRESS)
        rim = cylinder_ring((-0.7, -0.9, 0.0), 0.2, 0.2)
        b.explore("rim side", "half way round", rim, 0, 180)
        b.top_press("rim top 3 cm from the side, 6 cm deep", (-0.7 + 0.17, -0.9), 0.4, 0.12, PRESS)
        centre = (0.2, 1.4, 0.15)
        sphere = sphere_arc(centre, 0.15, 0.0)
        b.explore("small sphere", "stroke over the top", sphere, -40, 40)
        b.crease("small sphere", centre, 0.15, 0.0, APPROACH)
    else:
        raise ValueError(f"no fixed trajectory for scene {scene!r}; known: {', '.join(SCENES)}")
    return b.build(scene)


SCENES = ("contact-angle-v1", "texture-v1", "stiffness-v1", "shape-v1", "positioning-v1")
