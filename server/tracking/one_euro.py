"""The 1€ filter (Casiez, Roussel & Vogel 2012, "1€ Filter: A Simple Speed-based Low-pass Filter
for Noisy Input in Interactive Systems", CHI '12), exactly the paper's formulas.

For a sample X_i at time t_i (T_e = t_i − t_{i−1}):
    α(f_c)   = 1 / (1 + τ/T_e),  τ = 1 / (2π f_c)            (exponential smoothing factor)
    Ẋ_i      = (X_i − X̂_{i−1}) / T_e                          (derivative of the signal)
    Ẋ̂_i     = α(d_cutoff) Ẋ_i + (1 − α(d_cutoff)) Ẋ̂_{i−1}   (smoothed derivative)
    f_c      = f_c,min + β |Ẋ̂_i|                            (cutoff grows with speed)
    X̂_i     = α(f_c) X_i + (1 − α(f_c)) X̂_{i−1}
The first sample passes unfiltered (X̂_1 = X_1, Ẋ̂_1 = 0). A vector is filtered per coordinate
(the paper's scalar filter on each axis). Units: f_c in Hz, β in 1/(signal unit), times in s.

Defaults for a fingertip in scene units (docs/trackers.md "Filtering: the 1€ filter"): found with the
paper's procedure on `viestac bench tracking`'s noisy finger paths: β = 0, lower f_c,min until
the jitter at rest is gone, then raise β until the lag in fast moves is gone.

Pure: no clock (the caller passes each sample's time).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

DEFAULT_MIN_CUTOFF_HZ = 0.3
DEFAULT_BETA = 5.0
DEFAULT_D_CUTOFF_HZ = 1.0


@dataclass(frozen=True)
class OneEuroParams:
    min_cutoff_hz: float = DEFAULT_MIN_CUTOFF_HZ
    beta: float = DEFAULT_BETA
    d_cutoff_hz: float = DEFAULT_D_CUTOFF_HZ

    def __post_init__(self) -> None:
        if not (self.min_cutoff_hz > 0 and self.d_cutoff_hz > 0 and self.beta >= 0):
            raise ValueError("1€ filter: min_cutoff_hz and d_cutoff_hz must be > 0 and beta ≥ 0")

    @classmethod
    def from_dict(cls, table: dict) -> "OneEuroParams":
        return cls(**{k: float(v) for k, v in table.items() if k in ("min_cutoff_hz", "beta", "d_cutoff_hz")})

    def to_dict(self) -> dict:
        return {"min_cutoff_hz": self.min_cutoff_hz, "beta": self.beta, "d_cutoff_hz": self.d_cutoff_hz}


DEFAULT_PARAMS = OneEuroParams()


def alpha(cutoff_hz: float, te_s: float) -> float:
    tau = 1.0 / (2.0 * math.pi * cutoff_hz)
    return 1.0 / (1.0 + tau / te_s)


class OneEuro:
    """The scalar filter. `__call__(x, t_s)` → the filtered value."""

    __slots__ = ("params", "_x", "_dx", "_t")

    def __init__(self, params: OneEuroParams = OneEuroParams()):
        self.params = params
        self.reset()

    def reset(self) -> None:
        self._x: float | None = None
        self._dx = 0.0
        self._t = 0.0

    def __call__(self, x: float, t_s: float) -> float:
        if self._x is None:
            self._x, self._dx, self._t = x, 0.0, t_s
            return x
        te = t_s - self._t
        if te <= 0:  # a repeated or out-of-order timestamp: no new information about speed
            return self._x
        p = self.params
        dx = (x - self._x) / te
        a_d = alpha(p.d_cutoff_hz, te)
        self._dx = a_d * dx + (1.0 - a_d) * self._dx
        cutoff = p.min_cutoff_hz + p.beta * abs(self._dx)
        a = alpha(cutoff, te)
        self._x = a * x + (1.0 - a) * self._x
        self._t = t_s
        return self._x


class OneEuro3:
    """Three scalar filters, one per coordinate."""

    __slots__ = ("axes",)

    def __init__(self, params: OneEuroParams = OneEuroParams()):
        self.axes = (OneEuro(params), OneEuro(params), OneEuro(params))

    def reset(self) -> None:
        for axis in self.axes:
            axis.reset()

    def __call__(self, p, t_s: float) -> tuple[float, float, float]:
        return (self.axes[0](p[0], t_s), self.axes[1](p[1], t_s), self.axes[2](p[2], t_s))
