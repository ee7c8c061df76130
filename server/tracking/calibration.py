"""A source's calibration: its frame and units → the scene frame (a similarity transform).

    p_scene = scale · R · p_source + offset

`scale` carries the unit conversion (0.001 for millimetres → metres, times any scene scale), R
is a proper rotation (det +1), `offset` in scene units. Two routines an experimenter runs from
the console (docs/trackers.md "Calibration"):
- touch ≥ 3 marked scene points with the tracked finger: `fit` solves the least-squares
  similarity transform (Umeyama 1991, "Least-squares estimation of transformation parameters
  between two point patterns", IEEE TPAMI 13(4), via numpy's SVD) and reports the residual;
- hold still at one reference point: `hold_still` keeps R and scale and moves the offset so the
  held point lands on the reference (a tracker that was nudged).

Stored as JSON per rig and source name in the data dir (`store.py`). Pure: numpy only.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))

# The Leap Motion's frame (x right, y up, z towards the user, millimetres; origin at the
# device's centre) → the scene frame (z up; the default camera looks along −x, so +y is right and
# +x towards the viewer): scene x = leap z, scene y = leap x, scene z = leap y.
LEAP_AXES = ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0))
LEAP_DEFAULT_SCALE = 0.005        # scene units per mm: a 120 mm hand motion spans the 0.6-unit dome
LEAP_DEFAULT_OFFSET = (0.0, 0.0, -0.65)  # the Leap's sweet spot, 200 mm above it, at scene z = 0.35


@dataclass(frozen=True)
class Calibration:
    rotation: tuple = IDENTITY
    scale: float = 1.0
    offset: tuple = (0.0, 0.0, 0.0)
    units: str = "scene"          # the source's unit, for people (the conversion is in `scale`)
    residual: float | None = None  # RMS fit error of the routine that made it, scene units
    method: str = "default"       # default | points | hold
    meta: dict = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        r = np.asarray(self.rotation, dtype=float)
        if r.shape != (3, 3) or not np.allclose(r @ r.T, np.eye(3), atol=1e-6) or np.linalg.det(r) < 0:
            raise ValueError("calibration rotation must be a proper 3×3 rotation matrix")
        if not (np.isfinite(self.scale) and self.scale > 0):
            raise ValueError("calibration scale must be a finite number > 0")
        if len(self.offset) != 3 or not np.all(np.isfinite(self.offset)):
            raise ValueError("calibration offset must be three finite numbers")
        object.__setattr__(self, "_r", r)
        object.__setattr__(self, "_t", np.asarray(self.offset, dtype=float))

    def apply(self, p) -> tuple[float, float, float]:
        q = self.scale * (self._r @ np.asarray(p, dtype=float)) + self._t
        return (float(q[0]), float(q[1]), float(q[2]))

    def invert(self, q) -> tuple[float, float, float]:
        p = self._r.T @ (np.asarray(q, dtype=float) - self._t) / self.scale
        return (float(p[0]), float(p[1]), float(p[2]))

    def to_dict(self) -> dict:
        return {"rotation": [list(map(float, row)) for row in self._r], "scale": float(self.scale),
                "offset": [float(v) for v in self._t], "units": self.units, "residual": self.residual,
                "method": self.method, "meta": dict(self.meta)}

    @classmethod
    def from_dict(cls, table: dict) -> "Calibration":
        return cls(rotation=tuple(tuple(float(v) for v in row) for row in table["rotation"]),
                   scale=float(table["scale"]), offset=tuple(float(v) for v in table["offset"]),
                   units=str(table.get("units", "scene")), residual=table.get("residual"),
                   method=str(table.get("method", "points")), meta=dict(table.get("meta") or {}))


def leap_default() -> Calibration:
    return Calibration(rotation=LEAP_AXES, scale=LEAP_DEFAULT_SCALE, offset=LEAP_DEFAULT_OFFSET, units="mm")


def fit(source_points, scene_points, *, units: str = "scene", with_scale: bool = True) -> Calibration:
    """The least-squares similarity transform taking `source_points` onto `scene_points` (≥ 3
    pairs, not all on one line). ValueError when the points cannot define it."""
    src = np.asarray(source_points, dtype=float)
    dst = np.asarray(scene_points, dtype=float)
    if src.shape != dst.shape or src.ndim != 2 or src.shape[1] != 3 or len(src) < 3:
        raise ValueError("calibration needs at least 3 pairs of 3-D points")
    mu_s, mu_d = src.mean(axis=0), dst.mean(axis=0)
    a, b = src - mu_s, dst - mu_d
    var_s = float((a * a).sum() / len(src))
    cov = b.T @ a / len(src)
    u, sigma, vt = np.linalg.svd(cov)
    if var_s <= 1e-18 or sigma[1] <= 1e-9 * max(sigma[0], 1e-300):
        raise ValueError("the calibration points are (nearly) on one line or one spot: touch 3 points spread apart")
    d = np.ones(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:  # a reflection would fit better: take the best rotation
        d[2] = -1.0
    r = u @ np.diag(d) @ vt
    scale = float((sigma * d).sum() / var_s) if with_scale else 1.0
    t = mu_d - scale * r @ mu_s
    residual = float(np.sqrt(((scale * (r @ src.T).T + t - dst) ** 2).sum(axis=1).mean()))
    return Calibration(rotation=tuple(map(tuple, r.tolist())), scale=scale, offset=tuple(t.tolist()),
                       units=units, residual=residual, method="points")


def hold_still(current: Calibration, held_source_point, reference_scene_point) -> Calibration:
    """`current` with its offset moved so the point held still lands on the reference."""
    moved = np.asarray(current.apply(held_source_point))
    offset = np.asarray(current.offset, dtype=float) + np.asarray(reference_scene_point, dtype=float) - moved
    return Calibration(rotation=current.rotation, scale=current.scale, offset=tuple(offset.tolist()),
                       units=current.units, residual=0.0, method="hold")
