"""Constraint-based god-object (virtual proxy) on exact analytic primitives, solved in one tick.

Theory of operation
-------------------
The proxy is a massless point (or sphere of ``radius``) that follows the haptic interaction point
(HIP) but never enters a body; the force is the spring F = k (proxy - HIP) (Zilles & Salisbury
1995; Ruspini, Kolarov & Khatib 1997; thesis §3.3.1). Each tick:

1. Carry: if a body moved into the proxy, push it out to the nearest outside point (like
   CHAI3D's dynamic proxy; docs/reference.md "Haptic rendering").
2. Cast the segment proxy -> HIP against every body (``Body._cast``: exact and continuous, so a
   thin or fast-crossed object cannot be tunnelled, unlike the nearest-face penalty rule that
   pops through, CHAI3D's CShapeBox). No hit: the proxy goes to the HIP (free/released).
3. Hit: stop ON the surface (no epsilon back-off, which would bias the force: CHAI3D 3.3 keeps
   one) and make the tangent plane there a constraint. Slide to the sub-goal argmin |t - HIP|
   s.t. n_i.(t - q_i) >= 0 (Zilles & Salisbury's Lagrangian step, solved in closed form by
   ``vec.project_halfspaces``). Every slide move is itself cast-checked and a new hit adds its
   plane, so a concave crease (box on the ground) gets both planes in the SAME tick and the
   proxy lands on the crease line (CHAI3D's static mode finds one constraint per tick).
4. Repeat from the slid point toward the HIP. On a flat face the slide target lies on the face
   and the next cast confirms it. On a curved convex surface the tangent plane lies outside the
   body, so the slid point is in the air and the re-cast lands closer to the local minimum, at
   rate ~depth/R per iteration; at the iteration cap the proxy ends at the last hit point (on
   the surface) and keeps settling over the next ticks. A closest-point shortcut (``_shortcut``)
   usually finishes a smooth single contact in one iteration.

Point proxies can sit on edges, the cone apex and creases, so casts starting there use every
surface feature's normal, and faces glued to another body's face (a box standing on the ground)
are ignored: otherwise the point slides into the zero-thickness gap between the two bodies, the
analytic twin of a point god-object falling between adjacent polygons (Ruspini et al. 1997).
Friction (optional, one contact only): Ruspini's friction cone. Stick at the previous surface
position while |f_t| <= mu_s |f_n|; slipping lags the frictionless point by mu_d * depth; back
to sticking only inside the mu_d cone (hysteresis against stick/slip chatter, as CHAI3D does).
Pure floats, deterministic, no I/O, no clocks.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import inf, isfinite, sqrt
from typing import Sequence

from .compiled import chaptics
from .primitives import EPS_SURFACE, SHAPE_TYPES, Body
from .vec import Vec3, project_halfspaces

CONTACT_TOL = 1e-9  # |sd(proxy) - radius| <= this: the proxy touches that body
MAX_PLANES = 4  # constraint planes gathered per slide (3 independent ones fix a point)
CULL_MARGIN = 1e-9  # Lipschitz culling slack (> EPS_SURFACE, so on-surface starts are kept)
SHORTCUT_COS = 0.5  # closest-point shortcut only within 60 deg of the current normal
SHORTCUT_MIN = 1e-10  # below this (relative) the tangent planes count as one plane
PARALLEL = 1.0 - 1e-15  # cos^2 above which two directions count as parallel
GLUE_DOT = -1.0 + 1e-9  # feature normals with n.m <= this are opposite: glued faces
PUSH_STEPS = 3  # projections tried before the ray search when the proxy is inside one body
EXIT_REACH = 1e3  # scene units: farther than any scene object, to cast back from
ZERO: Vec3 = (0.0, 0.0, 0.0)
_AXES = ((1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, -1.0, 0.0),
         (0.0, 0.0, 1.0), (0.0, 0.0, -1.0))


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


def _sq(v: float) -> float:
    return v * v  # not v ** 2, which raises OverflowError past ~1e154 instead of giving inf


def _plane(ev, x):
    return (ev[1], ev[2], ev[3], ev[1] * x[0] + ev[2] * x[1] + ev[3] * x[2])


def _first_hit(bodies, phi0, start, a, b, radius, known=None, ki=-1, kev=None, skip=-1):
    """Earliest hit of segment a -> b: (t, point, body index, eval) or None; ties go to the
    first body. Bodies are culled with the 1-Lipschitz bound sd(p) >= sd(start) - |p - start|
    (phi0[i] = sd_i(start) - radius): the ground is skipped while stroking a dome. Evals at a:
    ``known`` (list, all bodies) or ``kev`` for body ``ki``; body ``skip`` is not tested."""
    sx, sy, sz = start
    # Squares as products: float ** 2 raises OverflowError past ~1e154 where x * x gives inf.
    ax, ay, az = a[0] - sx, a[1] - sy, a[2] - sz
    bx, by, bz = b[0] - sx, b[1] - sy, b[2] - sz
    ra = ax * ax + ay * ay + az * az
    rb = bx * bx + by * by + bz * bz
    reach = sqrt(ra if ra > rb else rb) + CULL_MARGIN
    idx = [i for i, f in enumerate(phi0) if f <= reach and i != skip]
    if not idx:
        return None
    if known is not None:
        evs = {i: known[i] for i in idx}
    else:
        evs = {i: (kev if i == ki else bodies[i]._eval(a)) for i in idx}
    dx, dy, dz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    feats = {}
    if radius == 0.0 and len(idx) > 1:
        on = [i for i in idx if -EPS_SURFACE < evs[i][0] <= EPS_SURFACE]
        if len(on) > 1:
            fs, un = _unglued_features(bodies, on, a, dx, dy, dz)
            feats = {i: un[i] for i in on if len(un[i]) < len(fs[i])}  # only if some glued
    best = None
    t_max = 1.0
    for i in idx:
        h = bodies[i]._cast(a, dx, dy, dz, radius, t_max, evs[i], feats.get(i))
        if h is not None and (best is None or h[0] < best[0]):
            best = (h[0], h[1], i, h[2])
            t_max = h[0]
    return best


def _unglued_features(bodies, on, a, dx, dy, dz):
    """Feature normals at a of the bodies in ``on`` (a lies on their surfaces) without the faces
    glued to another body's face (opposite normals at the same point). A body whose features
    are all glued keeps them (the ground under a box still blocks downward motion).
    Returns (all features, unglued features), both {body index: [normal, ...]}."""
    fs = {i: bodies[i]._features(a, dx, dy, dz) for i in on}
    out = {}
    for i in on:
        others = [m for j in on if j != i for m in fs[j]]
        keep = [n for n in fs[i] if all(n[0] * m[0] + n[1] * m[1] + n[2] * m[2] > GLUE_DOT
                                         for m in others)]
        out[i] = keep or fs[i]
    return fs, out


def _push_out(x, bodies, radius):
    """Move x out of every (dilated) body; returns (x, evals of every body at x) for the first
    cast. Inside one body: its closest dilated surface point. Inside several (a HIP inside a
    hemisphere standing on the ground): the nearest exit from their union along candidate rays
    (each body's exit normal, the six axes)."""
    evs = [b._eval(x) for b in bodies]
    inside = [i for i, ev in enumerate(evs) if ev[0] - radius <= -EPS_SURFACE]
    if not inside:
        return x, evs
    if len(inside) == 1:
        y, ev = x, evs[inside[0]]
        for _ in range(PUSH_STEPS):  # exact primitives land in one step; sampled fields need more
            f, nx, ny, nz = ev
            f -= radius
            y = (y[0] - f * nx, y[1] - f * ny, y[2] - f * nz)
            evy = [b._eval(y) for b in bodies]
            if min(ev[0] for ev in evy) - radius > -EPS_SURFACE:
                return y, evy
            ev = evy[inside[0]]
            if ev[0] - radius > -EPS_SURFACE:
                break  # out of this body but inside another: find the exit along rays
    best, best_d = x, inf
    for u in [ev[1:] for ev in evs] + list(_AXES):
        y = _exit_along(x, u, bodies, radius)
        if y is not None and (d := sum((y[k] - x[k]) * (y[k] - x[k]) for k in range(3))) < best_d:
            best, best_d = y, d
    return best, [b._eval(best) for b in bodies]


def _exit_along(x, u, bodies, radius):
    """First point of the ray x + s u (s >= 0) outside every dilated body, or None. Each convex
    body meets the ray in one interval, so jumping past the intervals containing the current
    point terminates; a body's exit comes from a cast back from far along the ray (None if the
    body is unbounded that way, like the ground straight down)."""
    p = x
    for _ in range(len(bodies) + 1):
        far_s = 0.0
        for b in bodies:
            if b._eval(p)[0] - radius > -EPS_SURFACE:
                continue
            d = (-EXIT_REACH * u[0], -EXIT_REACH * u[1], -EXIT_REACH * u[2])
            h = b._cast((p[0] - d[0], p[1] - d[1], p[2] - d[2]), *d, radius, 1.0, None)
            if h is None or h[0] == 0.0:
                return None
            far_s = max(far_s, EXIT_REACH * (1.0 - h[0]))
        if far_s == 0.0:
            return p
        p = (p[0] + far_s * u[0], p[1] + far_s * u[1], p[2] + far_s * u[2])
    return None


class ReferenceGodObject:
    """Stateful proxy for one HIP; call ``step`` once per servo tick (1 kHz). The readable
    reference: ``GodObject`` (below) is this class with its step compiled."""

    def __init__(self, radius: float = 0.0, *, max_iterations: int = 16,
                 tolerance: float = 1e-12, shortcut: bool = True) -> None:
        radius, tolerance = float(radius), float(tolerance)
        if not (isfinite(radius) and radius >= 0.0):
            raise ValueError(f"proxy radius must be finite and >= 0, got {radius!r}")
        if isinstance(max_iterations, bool) or not isinstance(max_iterations, int) \
                or max_iterations < 1:
            raise ValueError(f"max_iterations must be an int >= 1, got {max_iterations!r}")
        if not (isfinite(tolerance) and tolerance > 0.0):
            raise ValueError(f"tolerance must be finite and > 0, got {tolerance!r}")
        self.radius = radius
        self.max_iterations = max_iterations
        self.tolerance = tolerance
        # The closest-point shortcut trusts the bodies' distance fields to be exact; a sampled
        # field (bench baseline) blurs them deep inside, so it is switched off there.
        self.use_shortcut = bool(shortcut)
        self._proxy: Vec3 | None = None
        self._friction_body: str | None = None  # id of the one body touched last tick
        self._sticking = False

    @property
    def proxy(self) -> Vec3 | None:
        return self._proxy

    @property
    def sticking(self) -> bool:
        """The proxy is held in place by static friction (inside the friction cone)."""
        return self._sticking

    def reset(self, position: Vec3, bodies: Sequence[Body] = ()) -> None:
        """Place the proxy at ``position``, pushed out of any body it is inside of; forgets the
        friction state."""
        x = (float(position[0]), float(position[1]), float(position[2]))
        self._proxy = _push_out(x, bodies, self.radius)[0]
        self._friction_body = None
        self._sticking = False

    def forget(self) -> None:
        """Drop the proxy and the friction state: the next ``step`` starts from its HIP."""
        self._proxy = None
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
        hit_i, hit_ev, last_hit = -1, None, None  # body, its eval at the last hit point
        free = False
        iterations = 0
        shortcut = self.use_shortcut  # one closest-point shortcut attempt per tick
        hip_evs: dict = {}  # body index -> eval at the HIP (shared with the separation)
        for _ in range(self.max_iterations):
            iterations += 1
            hit = _first_hit(bodies, phi0, start, x, hip, r, pre)
            pre = None
            if hit is None:  # nothing between proxy and HIP: free, or released from contact
                x, free = hip, True
                break
            _, x, hit_i, hit_ev = hit
            if shortcut:
                shortcut = False
                jump = self._shortcut(bodies, phi0, start, x, hit_i, hit_ev, hip, hip_evs)
                if jump is not None:
                    x, hit_ev = jump
            last_hit = x
            planes = [_plane(hit_ev, x)]
            converged, slid = False, None
            while True:
                target = project_halfspaces(hip, planes)
                if target is None or ((target[0] - x[0]) * (target[0] - x[0]) + (target[1] - x[1])
                                      * (target[1] - x[1]) + (target[2] - x[2]) * (target[2] - x[2])) <= tol2:
                    converged = True  # x is the constrained minimum, on the surface
                    break
                h2 = _first_hit(bodies, phi0, start, x, target, r, None, hit_i, hit_ev)
                if h2 is None:
                    slid = target
                    break
                _, x, hit_i, hit_ev = h2
                last_hit = x
                if len(planes) == MAX_PLANES:
                    break
                planes.append(_plane(hit_ev, x))
            if converged:
                break
            if slid is not None:  # in the air above a curved surface: re-cast toward the HIP
                x = slid
        else:
            x = last_hit  # cap reached: end ON the surface, never at a slid point in the air

        # separation: exact sd(hip) only for bodies whose Lipschitz bound can be the minimum
        hx, hy, hz = hip[0] - start[0], hip[1] - start[1], hip[2] - start[2]
        dh = sqrt(hx * hx + hy * hy + hz * hz)
        sep = min((ev[0] for ev in hip_evs.values()), default=inf) - r
        for i, f in enumerate(phi0):
            if f - dh < sep and i not in hip_evs:
                sep = min(sep, bodies[i]._eval(hip)[0] - r)
        if free:
            self._proxy, self._friction_body, self._sticking = x, None, False
            return ProxyStep(x, ZERO, (), sep, iterations)

        gx, gy, gz = x[0] - start[0], x[1] - start[1], x[2] - start[2]
        dx = sqrt(gx * gx + gy * gy + gz * gz)
        near = [i for i, f in enumerate(phi0) if f - dx <= CONTACT_TOL + CULL_MARGIN]
        touched = self._touching(bodies, near, {hit_i: hit_ev} if x is last_hit else {}, x, hip)
        if not touched:  # numerically off every surface (should not happen): last hit body
            ev = bodies[hit_i]._eval(x)
            touched = [(hit_i, ev, 0.0)]
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
            self._friction_body, self._sticking = None, False

        k = bodies[touched[0][0]].stiffness_n_per_m if len(touched) == 1 else sum(
            bodies[i].stiffness_n_per_m for i, _, _ in touched) / len(touched)
        contacts = tuple(Contact(bodies[i].id, ev[1:], depth, (x[0] - r * ev[1], x[1] - r * ev[2],
                                                              x[2] - r * ev[3]))
                         for i, ev, depth in touched)
        self._proxy = x
        force = (k * (x[0] - hip[0]), k * (x[1] - hip[1]), k * (x[2] - hip[2]))
        return ProxyStep(x, force, contacts, sep, iterations)

    def _shortcut(self, bodies, phi0, start, x, i, ev_x, hip, hip_evs):
        """Closest-point shortcut for a smooth convex contact, accelerating the slide iteration
        (rate only ~depth/R per iteration on curved surfaces). The HIP's closest point c on the
        dilated body i is where sliding ends when c lies on the same smooth patch as x; the
        angle test n_x.n_c >= SHORTCUT_COS keeps c off other faces (adjacent patches of these
        primitives meet at >= 90 deg), so local minima on the current face are kept (path
        dependence). The proxy moves over the tent x -> m -> c, m on the line where the tangent
        planes at x and c meet: both support the convex body, so neither segment enters it;
        both are cast-checked against the other bodies. Returns (c, eval at c) or None."""
        r = self.radius
        ev = hip_evs.get(i)
        if ev is None:
            ev = hip_evs[i] = bodies[i]._eval(hip)
        f = ev[0] - r
        _, ax, ay, az = ev_x
        _, bx, by, bz = ev
        if f >= 0.0 or ax * bx + ay * by + az * bz < SHORTCUT_COS:
            return None  # HIP not inside body i (the segment crossed it), or another face
        c = (hip[0] - f * bx, hip[1] - f * by, hip[2] - f * bz)
        vx, vy, vz = c[0] - x[0], c[1] - x[1], c[2] - x[2]
        va = ax * vx + ay * vy + az * vz
        wx, wy, wz = vx - va * ax, vy - va * ay, vz - va * az  # x -> c within plane x
        den = bx * wx + by * wy + bz * wz
        if den <= SHORTCUT_MIN * sqrt(wx * wx + wy * wy + wz * wz):
            # one tangent plane (a flat face, or c within ~1e-10 of x): slide straight
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
        """Bodies (indices idx) whose dilated surface holds x, as (index, eval, depth); only
        those the HIP pushes into (depth > 0) if there are any. known: {i: eval at x}."""
        r = self.radius
        ex, ey, ez = x[0] - hip[0], x[1] - hip[1], x[2] - hip[2]
        on = []
        for i in idx:
            ev = known.get(i) or bodies[i]._eval(x)
            if abs(ev[0] - r) <= CONTACT_TOL:
                on.append((i, ev))
        if r == 0.0 and on and not (len(on) == 1 and _sq(on[0][1][1] * ex + on[0][1][2] * ey + on[
                0][1][3] * ez) >= (ex * ex + ey * ey + ez * ez) * PARALLEL):
            # A point proxy can rest on an edge, apex or crease: per body, report the (unglued)
            # feature normal the HIP pushes into most, or the body's own normal if better.
            fs, feats = _unglued_features(bodies, [i for i, _ in on], x, -ex, -ey, -ez)
            picked = []
            for i, ev in on:
                n = ev[1:]
                cands = feats[i] + ([n] if n not in fs[i] or n in feats[i] else [])
                picked.append((i, (ev[0],) + max(cands, key=lambda m: m[0] * ex + m[1] * ey
                                                 + m[2] * ez)))
            on = picked
        out = [(i, ev, max(0.0, ev[1] * ex + ev[2] * ey + ev[3] * ez)) for i, ev in on]
        return [c for c in out if c[2] > 0.0] or out

    def _friction(self, bodies, phi0, body, ev_x, x, hip, start):
        """Friction cone (Ruspini et al. 1997; CHAI3D testFrictionAndMoveProxy): returns the
        sticking position ``start`` (last tick's proxy), a lagging slip position, or x."""
        r = self.radius
        ev_s = body._eval(start)
        if abs(ev_s[0] - r) <= CONTACT_TOL:  # the previous proxy is still on this surface
            fx, fy, fz = start[0] - hip[0], start[1] - hip[1], start[2] - hip[2]
            fn = ev_s[1] * fx + ev_s[2] * fy + ev_s[3] * fz
            ft2 = fx * fx + fy * fy + fz * fz - fn * fn
            # hysteresis: once slipping, re-stick only inside the (narrower) dynamic cone
            mu = body.static_friction if self._sticking else body.dynamic_friction
            if fn > 0.0 and ft2 <= _sq(mu * fn):
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
        if h is None:
            h = _first_hit(bodies, phi0, start, cand, hip, r)
        return x if h is None else h[1]


def _on_core(name: str) -> property:
    return property(lambda self: getattr(self._core, name), lambda self, v: setattr(self._core, name, v))


class CompiledGodObject(ReferenceGodObject):
    """The god-object with its state and step in the compiled core (_chaptics.c): the same API and
    the same numbers as the reference. Bodies the core does not know (the bench's mesh and grid
    baselines) take the reference's step, on the same state."""

    def __init__(self, radius: float = 0.0, *, max_iterations: int = 16, tolerance: float = 1e-12,
                 shortcut: bool = True) -> None:
        self._core = chaptics.GodCore()
        super().__init__(radius, max_iterations=max_iterations, tolerance=tolerance, shortcut=shortcut)

    radius = _on_core("radius")
    max_iterations = _on_core("max_iterations")
    tolerance = _on_core("tolerance")
    use_shortcut = _on_core("use_shortcut")
    _proxy = _on_core("proxy")
    _friction_body = _on_core("friction_body")
    _sticking = _on_core("sticking")

    @property
    def sticking(self) -> bool:  # read every tick (TickContext.sticking): one property, not two
        return self._core.sticking

    def step(self, bodies: Sequence[Body], hip: Vec3) -> ProxyStep:
        s = self._core.step(bodies, hip)
        return ReferenceGodObject.step(self, bodies, hip) if s is None else s

    # The state lives in the C object, which copy and pickle cannot see: hand it over explicitly.
    _STATE = ("radius", "max_iterations", "tolerance", "use_shortcut", "_proxy", "_friction_body", "_sticking")

    def __getstate__(self) -> dict:
        return {name: getattr(self, name) for name in self._STATE}

    def __setstate__(self, state: dict) -> None:
        self._core = chaptics.GodCore()
        for name in self._STATE:
            setattr(self, name, state[name])


if chaptics is not None:
    chaptics.configure(Body, SHAPE_TYPES, ProxyStep, Contact)
    GodObject: type[ReferenceGodObject] = CompiledGodObject
else:
    GodObject = ReferenceGodObject
