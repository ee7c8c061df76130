"""Constraint-based god-object (virtual proxy) on exact analytic primitives, solved in one tick.

Theory of operation
-------------------
The proxy is a massless point (or sphere of ``radius``) that follows the haptic interaction point
(HIP) but never enters a body; the rendered force is the spring F = k (proxy - HIP) (Zilles &
Salisbury 1995; Ruspini, Kolarov & Khatib 1997; spec.md "Haptic rendering"). Each tick:

1. Carry: if a body moved into the proxy, push the proxy to that body's closest dilated surface
   point (like CHAI3D's dynamic proxy, rendering-notes.md 1.4).
2. Cast the segment proxy -> HIP against every body (``Body.cast``: exact, continuous, so thin or
   fast-crossed objects cannot be tunnelled, unlike the nearest-face penalty rule that pops
   through, rendering-notes.md 1.3). No hit: the proxy goes to the HIP (free or released).
3. Hit: stop ON the surface (no epsilon back-off: CHAI3D keeps an epsilon gap which biases the
   force, 1.4) and add the tangent plane there as a constraint. Slide: the sub-goal is
   argmin |t - HIP| s.t. n_i.(t - q_i) >= 0 over the constraint planes (Zilles & Salisbury's
   Lagrangian step; done here by closed-form active-set enumeration over <= 3 planes instead of a
   6x6 solve, which costs ~25 us in numpy vs < 1 us, rendering-notes.md 1.1). Every slide move is
   itself cast-checked; a new hit adds its plane (up to 4), so a concave crease (box on the
   ground) gets both planes in the SAME tick and the proxy lands on the crease line (CHAI3D finds
   one constraint per tick in static mode and needs up to 3 ticks).
4. Repeat from the slid point toward the HIP. On flat faces the slide target lies on the face and
   the next cast confirms it (2 iterations). On a curved convex surface the tangent plane lies
   outside the body, so the slid point is in the air and the re-cast toward the HIP lands closer
   to the HIP's closest point, converging geometrically at rate ~depth/R per iteration; with the
   iteration cap hit, the proxy ends at the last hit point (on the surface) and keeps settling
   over the next ticks.

Friction (optional, only with exactly one contact): Ruspini-style friction cone. The proxy sticks
at its previous surface position while |f_t| <= mu_s |f_n|; when slipping it lags the
frictionless point by mu_d * depth; slipping returns to sticking only inside the mu_d cone
(hysteresis against stick/slip chatter, as CHAI3D does, rendering-notes.md 1.4).
Pure floats, deterministic, no I/O, no clocks.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import inf, isfinite, sqrt
from typing import Sequence

from .primitives import EPS_SURFACE, Body
from .vec import Vec3

CONTACT_TOL = 1e-9  # |sd(proxy) - radius| <= this: the proxy touches that body
FEAS_TOL = 1e-12  # slack of the plane constraints n.(t - q) >= 0 in the slide QP
PARALLEL_TOL = 1e-10  # 1 - (n_i.n_j)^2 below this (angle < ~1e-5 rad): pair skipped
TRIPLE_TOL = 1e-8  # |n1.(n2 x n3)| below this: triple skipped
MAX_PLANES = 4  # constraint planes gathered per slide (3 independent ones fix a point)
PUSH_PASSES = 3
CULL_MARGIN = 1e-9  # Lipschitz culling slack (> EPS_SURFACE, so on-surface starts are kept)
SHORTCUT_COS = 0.5  # closest-point shortcut only within 60 deg of the current normal
SHORTCUT_MIN = 1e-10  # ... and only if the tangent planes are not (nearly) parallel
PARALLEL = 1.0 - 1e-15  # cos^2 above which two directions count as parallel
GLUE_DOT = -1.0 + 1e-9  # feature normals with n.m <= this are opposite (glued faces)
ZERO: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Contact:
    body_id: str
    normal: Vec3  # outward unit normal (world) at the touched surface point
    depth: float  # how far the HIP is past the proxy along the normal (>= 0)
    point: Vec3  # surface point touched: proxy - radius * normal


@dataclass(frozen=True)
class ProxyStep:
    proxy: Vec3
    force: Vec3  # k (proxy - hip), k = mean stiffness of the touched bodies; zero when free
    contacts: tuple[Contact, ...]
    separation: float  # min over bodies of sd(hip) - radius; > 0: HIP outside every body
    iterations: int


def _first_hit(bodies, phi0, start, a, b, radius, known=None, ki=-1, kev=None, skip=-1):
    """Earliest hit of segment a -> b over all bodies: (t, point, body index, eval) or None;
    ties go to the first body (deterministic). Bodies are culled with the 1-Lipschitz bound
    sd(p) >= sd(start) - |p - start| (phi0[i] = sd_i(start) - radius): a body farther from the
    tick's start than the segment reaches cannot be hit, which skips the ground while stroking
    a dome. Evals at a: ``known`` (list for all bodies) or ``kev`` for body ``ki``; body
    ``skip`` is not tested (the caller proved the segment cannot enter it)."""
    sx, sy, sz = start
    ra = (a[0] - sx) ** 2 + (a[1] - sy) ** 2 + (a[2] - sz) ** 2
    rb = (b[0] - sx) ** 2 + (b[1] - sy) ** 2 + (b[2] - sz) ** 2
    reach = sqrt(ra if ra > rb else rb) + CULL_MARGIN
    idx = [i for i, f in enumerate(phi0) if f <= reach and i != skip]
    if not idx:
        return None
    if known is not None:
        evs = {i: known[i] for i in idx}
    else:
        evs = {i: (kev if i == ki else bodies[i]._eval(a)) for i in idx}
    dx = b[0] - a[0]
    dy = b[1] - a[1]
    dz = b[2] - a[2]
    feats = None
    if radius == 0.0 and len(idx) > 1:
        on = [i for i in idx if -EPS_SURFACE < evs[i][0] <= EPS_SURFACE]
        if len(on) > 1:
            fs, un = _unglued_features(bodies, on, a, dx, dy, dz)
            feats = {i: un[i] for i in on if len(un[i]) < len(fs[i])}  # only if some glued
    best = None
    t_max = 1.0
    for i in idx:
        h = bodies[i]._cast(a, dx, dy, dz, radius, t_max, evs[i],
                            None if feats is None else feats.get(i))
        if h is not None and (best is None or h[0] < best[0]):
            best = (h[0], h[1], i, h[2])
            t_max = h[0]
    return best


def _unglued_features(bodies, on, a, dx, dy, dz):
    """Feature normals at a of the bodies whose surface a lies on, minus faces glued to another
    body's face (opposite normals at the same point: a box standing on the ground, two boxes
    side by side). A point proxy could otherwise slide into the zero-thickness gap between two
    touching bodies, which is inside their union: the analytic twin of the point god-object's
    fall-through between adjacent polygons (rendering-notes.md 1.3). A body keeps all its
    features if all of them are glued (the ground under a box still blocks downward motion).
    Returns (all features, unglued features), both {body index: [normal, ...]}."""
    fs = {i: bodies[i]._features(a, dx, dy, dz) for i in on}
    out = {}
    for i in on:
        others = [m for j in on if j != i for m in fs[j]]
        keep = [n for n in fs[i] if all(n[0] * m[0] + n[1] * m[1] + n[2] * m[2] > GLUE_DOT
                                         for m in others)]
        out[i] = keep or fs[i]
    return fs, out


def _solve_qp(h, planes):
    """argmin |t - h| s.t. n_i.t >= c_i for planes (nx, ny, nz, c): enumerate the closed-form
    candidates (h itself, projection on one plane, on the line of two, the point of three),
    keep the feasible one nearest h. The true minimiser is the projection of h onto the affine
    hull of its active set, so it is among the candidates. None if every candidate is
    degenerate or infeasible (the caller then keeps the proxy where it is)."""
    hx, hy, hz = h
    if len(planes) == 1:  # the common case, ~1 us
        nx, ny, nz, c = planes[0]
        s = nx * hx + ny * hy + nz * hz - c
        if s >= 0.0:
            return h
        return (hx - s * nx, hy - s * ny, hz - s * nz)
    viol = [nx * hx + ny * hy + nz * hz - c for nx, ny, nz, c in planes]
    if min(viol) >= -FEAS_TOL:
        return h

    def feasible(t):
        tx, ty, tz = t
        return all(nx * tx + ny * ty + nz * tz - c >= -FEAS_TOL for nx, ny, nz, c in planes)

    best = None
    best_d2 = inf
    m = len(planes)
    for i in range(m):
        s = viol[i]
        if s < 0.0 and s * s < best_d2:
            nx, ny, nz, _ = planes[i]
            t = (hx - s * nx, hy - s * ny, hz - s * nz)
            if feasible(t):
                best, best_d2 = t, s * s
    for i in range(m):
        ax, ay, az, _ = planes[i]
        for j in range(i + 1, m):
            bx, by, bz, _ = planes[j]
            g = ax * bx + ay * by + az * bz
            det = 1.0 - g * g
            if det < PARALLEL_TOL:
                continue
            p = (viol[i] - g * viol[j]) / det
            q = (viol[j] - g * viol[i]) / det
            ox, oy, oz = p * ax + q * bx, p * ay + q * by, p * az + q * bz
            d2 = ox * ox + oy * oy + oz * oz
            if d2 < best_d2:
                t = (hx - ox, hy - oy, hz - oz)
                if feasible(t):
                    best, best_d2 = t, d2
    for i in range(m):
        for j in range(i + 1, m):
            for k in range(j + 1, m):
                t = _three_planes(planes[i], planes[j], planes[k])
                if t is not None:
                    d2 = (t[0] - hx) ** 2 + (t[1] - hy) ** 2 + (t[2] - hz) ** 2
                    if d2 < best_d2 and feasible(t):
                        best, best_d2 = t, d2
    return best


def _three_planes(p1, p2, p3):
    """Intersection point of three planes n.t = c by Cramer's rule, None if near-degenerate."""
    ax, ay, az, c1 = p1
    bx, by, bz, c2 = p2
    cx, cy, cz, c3 = p3
    ux, uy, uz = by * cz - bz * cy, bz * cx - bx * cz, bx * cy - by * cx  # n2 x n3
    vx, vy, vz = cy * az - cz * ay, cz * ax - cx * az, cx * ay - cy * ax  # n3 x n1
    wx, wy, wz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx  # n1 x n2
    det = ax * ux + ay * uy + az * uz
    if abs(det) < TRIPLE_TOL:
        return None
    return ((c1 * ux + c2 * vx + c3 * wx) / det, (c1 * uy + c2 * vy + c3 * wy) / det,
            (c1 * uz + c2 * vz + c3 * wz) / det)


def _push_out(x, bodies, radius):
    """Move x out of any (dilated) body it is inside of, deepest first, to that body's closest
    dilated surface point; returns (x, evals of every body at x) for reuse by the first cast."""
    evs = [b._eval(x) for b in bodies]
    for _ in range(PUSH_PASSES):
        worst = -1
        worst_f = -EPS_SURFACE
        for i, ev in enumerate(evs):
            f = ev[0] - radius
            if f <= worst_f:
                worst, worst_f = i, f
        if worst < 0:
            break
        _, nx, ny, nz = evs[worst]
        x = (x[0] - worst_f * nx, x[1] - worst_f * ny, x[2] - worst_f * nz)
        evs = [b._eval(x) for b in bodies]
    return x, evs


class GodObject:
    """Stateful proxy for one HIP. ``step`` once per servo tick (1 kHz)."""

    def __init__(self, radius: float = 0.0, *, max_iterations: int = 16,
                 tolerance: float = 1e-12) -> None:
        radius = float(radius)
        if not (isfinite(radius) and radius >= 0.0):
            raise ValueError(f"proxy radius must be finite and >= 0, got {radius!r}")
        if isinstance(max_iterations, bool) or not isinstance(max_iterations, int) \
                or max_iterations < 1:
            raise ValueError(f"max_iterations must be an int >= 1, got {max_iterations!r}")
        tolerance = float(tolerance)
        if not (isfinite(tolerance) and tolerance > 0.0):
            raise ValueError(f"tolerance must be finite and > 0, got {tolerance!r}")
        self.radius = radius
        self.max_iterations = max_iterations
        self.tolerance = tolerance
        self._proxy: Vec3 | None = None
        self._friction_body: str | None = None  # body the proxy touched last tick
        self._sticking = False

    @property
    def proxy(self) -> Vec3 | None:
        return self._proxy

    def reset(self, position: Vec3, bodies: Sequence[Body] = ()) -> None:
        """Place the proxy at ``position``, pushed out to the closest dilated surface point if
        inside a body; forgets friction state."""
        x = (float(position[0]), float(position[1]), float(position[2]))
        self._proxy = _push_out(x, bodies, self.radius)[0]
        self._friction_body = None
        self._sticking = False

    def step(self, bodies: Sequence[Body], hip: Vec3) -> ProxyStep:
        hip = (float(hip[0]), float(hip[1]), float(hip[2]))
        r = self.radius
        if self._proxy is None:
            self.reset(hip, bodies)
        start, pre = _push_out(self._proxy, bodies, r)
        phi0 = [ev[0] - r for ev in pre]
        x = start
        tol2 = self.tolerance * self.tolerance
        hit_ev = None  # eval of the body (index hit_i) at the last hit point last_hit
        hit_i = -1
        last_hit = None
        free = False
        iterations = 0
        shortcut = True  # one closest-point shortcut attempt per tick
        hip_evs = {}  # body index -> eval at the HIP (shared with the separation below)
        for _ in range(self.max_iterations):
            iterations += 1
            hit = _first_hit(bodies, phi0, start, x, hip, r, pre)
            pre = None
            if hit is None:  # nothing between proxy and HIP: free, or released from contact
                x = hip
                free = True
                break
            _, x, hit_i, hit_ev = hit
            if shortcut:
                shortcut = False
                jump = self._shortcut(bodies, phi0, start, x, hit_i, hit_ev, hip, hip_evs)
                if jump is not None:
                    x, hit_ev = jump
            last_hit = x
            planes = [(hit_ev[1], hit_ev[2], hit_ev[3],
                       hit_ev[1] * x[0] + hit_ev[2] * x[1] + hit_ev[3] * x[2])]
            converged = False
            slid = None
            while True:
                target = _solve_qp(hip, planes)
                if target is None or ((target[0] - x[0]) ** 2 + (target[1] - x[1]) ** 2
                                      + (target[2] - x[2]) ** 2) <= tol2:
                    converged = True  # x is the constrained minimum: on the surface
                    break
                h2 = _first_hit(bodies, phi0, start, x, target, r, None, hit_i, hit_ev)
                if h2 is None:
                    slid = target
                    break
                _, x, hit_i, hit_ev = h2
                last_hit = x
                if len(planes) == MAX_PLANES:
                    break
                planes.append((hit_ev[1], hit_ev[2], hit_ev[3],
                               hit_ev[1] * x[0] + hit_ev[2] * x[1] + hit_ev[3] * x[2]))
            if converged:
                break
            if slid is not None:  # in the air above a curved surface: re-cast toward the HIP
                x = slid
        else:
            x = last_hit  # cap reached: end ON the surface, never at a slid point in the air

        # separation: exact sd(hip) only for bodies whose Lipschitz bound could be the minimum
        dh = sqrt((hip[0] - start[0]) ** 2 + (hip[1] - start[1]) ** 2
                  + (hip[2] - start[2]) ** 2)
        sep = inf
        for f, i in sorted((f - dh, i) for i, f in enumerate(phi0)):
            if f >= sep:
                break
            ev = hip_evs.get(i) or bodies[i]._eval(hip)
            v = ev[0] - r
            if v < sep:
                sep = v

        if free:
            self._proxy = x
            self._friction_body = None
            self._sticking = False
            return ProxyStep(x, ZERO, (), sep, iterations)

        dx_ = sqrt((x[0] - start[0]) ** 2 + (x[1] - start[1]) ** 2 + (x[2] - start[2]) ** 2)
        near = [i for i, f in enumerate(phi0) if f - dx_ <= CONTACT_TOL + CULL_MARGIN]
        known = {hit_i: hit_ev} if x is last_hit else {}
        touched = self._touching(bodies, near, known, x, hip)
        if not touched:  # numerically off every surface (should not happen): last hit body
            ev = bodies[hit_i]._eval(x)
            touched = [(hit_i, ev, max(0.0, ev[1] * (x[0] - hip[0]) + ev[2] * (
                x[1] - hip[1]) + ev[3] * (x[2] - hip[2])))]
        if len(touched) == 1:
            body = bodies[touched[0][0]]
            rough = body.static_friction > 0.0 or body.dynamic_friction > 0.0
            if rough and self._friction_body == body.id:
                x2 = self._friction(bodies, phi0, body, touched[0][1], x, hip, start)
                if x2 is not x:
                    x = x2
                    touched = self._touching(bodies, range(len(bodies)), {}, x, hip) or touched
            else:  # just landed (or frictionless): at rest, so static friction applies first
                self._sticking = rough
            self._friction_body = body.id
        else:
            self._friction_body = None
            self._sticking = False

        k = 0.0
        contacts = []
        for i, ev, depth in touched:
            k += bodies[i].stiffness_n_per_m
            contacts.append(Contact(bodies[i].id, (ev[1], ev[2], ev[3]), depth,
                                    (x[0] - r * ev[1], x[1] - r * ev[2], x[2] - r * ev[3])))
        k /= len(touched)
        self._proxy = x
        force = (k * (x[0] - hip[0]), k * (x[1] - hip[1]), k * (x[2] - hip[2]))
        return ProxyStep(x, force, tuple(contacts), sep, iterations)

    def _shortcut(self, bodies, phi0, start, x, i, ev_x, hip, hip_evs):
        """Closest-point shortcut for one smooth convex contact, an accelerator of the slide
        iteration (which converges only at rate ~depth/R per iteration on curved surfaces).
        c = the HIP's closest point on the dilated body i is where sliding ends when c lies on
        the same smooth patch as x; the angle test n_x.n_c >= SHORTCUT_COS keeps c off other
        faces (all adjacent patches of these primitives meet at >= 90 deg), so local minima
        on the current face are kept (path dependence). The proxy moves over the tent x -> m
        -> c, m on the line where the tangent planes at x and c meet: both planes support the
        convex body, so neither segment enters it; both are cast-checked against the other
        bodies. Returns (c, eval at c) or None (then the iteration runs as usual)."""
        r = self.radius
        ev = hip_evs.get(i)
        if ev is None:
            ev = hip_evs[i] = bodies[i]._eval(hip)
        f = ev[0] - r
        if f >= 0.0:  # HIP not inside this body (the segment crossed it): no shortcut
            return None
        _, ax, ay, az = ev_x
        _, bx, by, bz = ev
        if ax * bx + ay * by + az * bz < SHORTCUT_COS:
            return None
        c = (hip[0] - f * bx, hip[1] - f * by, hip[2] - f * bz)
        vx, vy, vz = c[0] - x[0], c[1] - x[1], c[2] - x[2]
        va = ax * vx + ay * vy + az * vz
        wx, wy, wz = vx - va * ax, vy - va * ay, vz - va * az  # x -> c within plane x
        den = bx * wx + by * wy + bz * wz
        if den <= SHORTCUT_MIN * sqrt(wx * wx + wy * wy + wz * wz):
            # same tangent plane (a flat face, or c within ~1e-10 of x): slide straight
            if _first_hit(bodies, phi0, start, x, c, r, None, i, ev_x) is not None:
                return None
            return c, (r, bx, by, bz)
        beta = (bx * vx + by * vy + bz * vz) / den
        m = (x[0] + beta * wx, x[1] + beta * wy, x[2] + beta * wz)
        if _first_hit(bodies, phi0, start, x, m, r, None, i, ev_x) is not None \
                or _first_hit(bodies, phi0, start, m, c, r, skip=i) is not None:
            return None
        return c, (r, bx, by, bz)

    def _touching(self, bodies, idx, known, x, hip):
        """Bodies (among indices idx) whose dilated surface holds x, as (index, eval, depth);
        only those the HIP pushes into (depth > 0) when there are any. known: {i: eval at x}."""
        r = self.radius
        ex, ey, ez = x[0] - hip[0], x[1] - hip[1], x[2] - hip[2]
        on = []
        for i in idx:
            ev = known.get(i) or bodies[i]._eval(x)
            if abs(ev[0] - r) <= CONTACT_TOL:
                on.append((i, ev))
        e2 = ex * ex + ey * ey + ez * ez
        if r == 0.0 and on and not (len(on) == 1 and (
                on[0][1][1] * ex + on[0][1][2] * ey + on[0][1][3] * ez) ** 2 >= e2 * PARALLEL):
            # A point proxy can rest on an edge, apex or crease: per body, report the (unglued)
            # feature normal the HIP pushes into most, or the body's own normal if better.
            # (Skipped for one body whose normal is already parallel to proxy - HIP.)
            fs, feats = _unglued_features(bodies, [i for i, _ in on], x, -ex, -ey, -ez)
            picked = []
            for i, ev in on:
                cands = list(feats[i])
                n = ev[1:]
                if n not in fs[i] or n in feats[i]:  # own normal unless it is a glued face
                    cands.append(n)
                n = max(cands, key=lambda m: m[0] * ex + m[1] * ey + m[2] * ez)
                picked.append((i, (ev[0],) + n))
            on = picked
        out = []
        for i, ev in on:
            depth = ev[1] * ex + ev[2] * ey + ev[3] * ez
            out.append((i, ev, depth if depth > 0.0 else 0.0))
        pushed = [c for c in out if c[2] > 0.0]
        return pushed or out

    def _friction(self, bodies, phi0, body, ev_x, x, hip, start):
        """Friction cone (Ruspini et al. 1997; CHAI3D testFrictionAndMoveProxy): returns the
        sticking position ``start`` (last tick's proxy), a lagging slip position, or x."""
        r = self.radius
        ev_s = body._eval(start)
        if abs(ev_s[0] - r) <= CONTACT_TOL:  # previous proxy still on this surface: may stick
            fx, fy, fz = start[0] - hip[0], start[1] - hip[1], start[2] - hip[2]
            fn = ev_s[1] * fx + ev_s[2] * fy + ev_s[3] * fz
            ft2 = fx * fx + fy * fy + fz * fz - fn * fn
            # hysteresis: once slipping, re-stick only inside the (narrower) dynamic cone
            mu = body.static_friction if self._sticking else body.dynamic_friction
            if fn > 0.0 and ft2 <= (mu * fn) ** 2:
                self._sticking = True
                return start
        self._sticking = False
        # slipping: lag the frictionless point by mu_d * depth toward the previous position,
        # within the tangent plane at x, then settle back onto the surface toward the HIP
        nx, ny, nz = ev_x[1], ev_x[2], ev_x[3]
        depth = nx * (x[0] - hip[0]) + ny * (x[1] - hip[1]) + nz * (x[2] - hip[2])
        vx, vy, vz = start[0] - x[0], start[1] - x[1], start[2] - x[2]
        vn = nx * vx + ny * vy + nz * vz
        vx, vy, vz = vx - vn * nx, vy - vn * ny, vz - vn * nz
        lt = sqrt(vx * vx + vy * vy + vz * vz)
        lag = body.dynamic_friction * depth
        if lag <= 0.0 or lt == 0.0:
            return x
        s = min(lag, lt) / lt
        cand = (x[0] + s * vx, x[1] + s * vy, x[2] + s * vz)
        h = _first_hit(bodies, phi0, start, x, cand, r)
        if h is not None:
            return h[1]
        h = _first_hit(bodies, phi0, start, cand, hip, r)
        return x if h is None else h[1]
