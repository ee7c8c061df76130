"""Contact methods compared by `viestac bench accuracy` and `viestac bench stability`.

Every method answers the same question each tick: given the HIP, where is the proxy, what is the
force k (proxy - HIP), and is there contact? They differ in how the geometry is represented and
how the proxy is found:

* ``analytic``: the server's god-object (server/core/haptics/god_object.py) on the exact primitives:
  the compiled core when it is built; `viestac bench accuracy` also runs the Python reference
  (``analytic (Python reference)``, same numbers, its own cost).
* ``mesh``: the same god-object on triangle-mesh tessellations of the primitives
  (server/bench/mesh_shape.py): the geometry error of a tessellation, at a mesh query's cost.
* ``sdf``: the same god-object on signed-distance grids sampled from the primitives
  (server/bench/sdf_grid.py): interpolation error and a sphere-traced cast.
* ``penalty``: no proxy memory at all; the nearest surface point of the HIP's current sample,
  like CHAI3D's analytic shapes (cShape*::computeLocalInteraction + cEffectSurface,
  docs/reference.md "Haptic rendering"), with its pop-through and tunnelling.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache
from typing import Sequence

from server.core.haptics.god_object import GodObject, ReferenceGodObject
from server.bench.mesh_shape import LEVELS, MeshShape
from server.core.haptics.compiled import COMPILED
from server.core.haptics.primitives import Body, _Shape
from server.bench.sdf_grid import CELLS, GridBody, GridShape
from server.core.haptics.vec import Vec3

ZERO: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class MethodStep:
    proxy: Vec3
    force: Vec3  # k (proxy - HIP); zero when free
    contact: bool


class ContactMethod:
    """One method at one resolution. ``family`` groups resolutions of the same method on a chart;
    ``label`` names the point ("mesh L2", "sdf 32"); ``detail`` says what the resolution means."""

    family: str = ""

    def __init__(self, label: str, detail: str = "") -> None:
        self.label = label
        self.detail = detail

    def reset(self) -> None:
        """Forget any proxy memory (a new trajectory starts)."""

    def step(self, hip: Vec3) -> MethodStep:
        raise NotImplementedError


class ProxyMethod(ContactMethod):
    """The god-object on some representation of the bodies (analytic, mesh or grid bodies)."""

    def __init__(self, family: str, label: str, bodies: Sequence[Body], radius: float, detail: str = "",
                 exact: bool = True, god: type[ReferenceGodObject] = GodObject) -> None:
        super().__init__(label, detail)
        self.family = family
        self.bodies = tuple(bodies)  # a tuple: the compiled core checks an unchanged scene by identity
        self.radius = radius
        self.exact = exact  # exact distance fields: the god-object may use its closest-point shortcut
        self.god = god
        self._god = god(radius, shortcut=exact)

    def reset(self) -> None:
        self._god = self.god(self.radius, shortcut=self.exact)

    def step(self, hip: Vec3) -> MethodStep:
        s = self._god.step(self.bodies, hip)
        return MethodStep(s.proxy, s.force, bool(s.contacts))


class PenaltyMethod(ContactMethod):
    """Stateless nearest-surface rule: inside the (dilated) body nearest to the HIP, the proxy is
    that body's closest surface point, whichever face that is. A thin plate pushed past its
    mid-plane pushes the HIP out of the far side; a sample that jumps over it sees nothing."""

    family = "penalty"

    def __init__(self, bodies: Sequence[Body], radius: float) -> None:
        super().__init__("penalty", "nearest surface point of the current sample (CHAI3D cShape*)")
        self.bodies = list(bodies)
        self.radius = radius

    def step(self, hip: Vec3) -> MethodStep:
        # CHAI3D's potential-field pass sums every object's interaction force, so a HIP inside
        # two bodies (a crease) is pushed by both
        fx = fy = fz = 0.0
        ox = oy = oz = 0.0  # summed displacement to each body's surface point
        touched = 0
        for body in self.bodies:
            sd, nx, ny, nz = body._eval(hip)
            f = sd - self.radius
            if f < 0.0:
                k = body.stiffness_n_per_m
                ox, oy, oz = ox - f * nx, oy - f * ny, oz - f * nz
                fx, fy, fz = fx - k * f * nx, fy - k * f * ny, fz - k * f * nz
                touched += 1
        if not touched:
            return MethodStep(hip, ZERO, False)
        return MethodStep((hip[0] + ox, hip[1] + oy, hip[2] + oz), (fx, fy, fz), True)


@lru_cache(maxsize=256)
def _mesh(shape: _Shape, level: int) -> MeshShape:
    return MeshShape.of(shape, level)


@lru_cache(maxsize=4)  # a 128-cell grid of a scene's body holds millions of nodes
def _grid(shape: _Shape, cells: int, margin: float) -> GridShape:
    return GridShape(shape, cells, margin)


def mesh_bodies(bodies: Sequence[Body], level: int) -> list[Body]:
    return [replace(b, shape=_mesh(b.shape, level)) for b in bodies]


def grid_bodies(bodies: Sequence[Body], cells: int, margin: float) -> list[Body]:
    return [GridBody(b.id, _grid(b.shape, cells, margin), b.pose, b.stiffness_n_per_m, b.static_friction,
                     b.dynamic_friction) for b in bodies]


QUICK_LEVELS = (1, 3)
QUICK_CELLS = (16, 32)


def build_methods(bodies: Sequence[Body], radius: float, *, quick: bool = False) -> list[ContactMethod]:
    """Every method × resolution for these bodies (the reduced set when ``quick``): the analytic
    god-object, the god-object on mesh tessellations and on signed-distance grids, the penalty."""
    bodies = list(bodies)
    methods: list[ContactMethod] = [ProxyMethod("analytic", "analytic", bodies, radius, "exact primitives"
                                                 + (", compiled core" if COMPILED else ", Python (core not built)"))]
    for level in QUICK_LEVELS if quick else LEVELS:
        meshed = mesh_bodies(bodies, level)
        faces = sum(b.shape.faces for b in meshed)
        methods.append(ProxyMethod("mesh", f"mesh L{level}", meshed, radius, f"{faces} triangles"))
    margin = radius + 0.1  # the grid covers the free space where the (dilated) contact happens
    for cells in QUICK_CELLS if quick else CELLS:
        gridded = grid_bodies(bodies, cells, margin)
        hs = sorted({round(b.shape.h * 1000, 1) for b in gridded})
        methods.append(ProxyMethod("sdf", f"sdf {cells}", gridded, radius,
                                   f"{cells} cells across each body, h = {hs[0]:g}–{hs[-1]:g} mm"
                                   if len(hs) > 1 else f"{cells} cells across each body, h = {hs[0]:g} mm",
                                   exact=False))
    methods.append(PenaltyMethod(bodies, radius))
    return methods


def reference_method(bodies: Sequence[Body], radius: float) -> ProxyMethod:
    """The god-object's readable Python reference on the exact primitives: the analytic method's
    numbers at the reference's cost (what the compiled core saves)."""
    return ProxyMethod("analytic", REFERENCE_LABEL, bodies, radius, "exact primitives, Python reference",
                       god=ReferenceGodObject)


REFERENCE_LABEL = "analytic (Python reference)"
