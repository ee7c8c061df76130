"""Psychometric functions: one parametrisation for every family (docs/psychophysics.md).

    p(x) = γ + (1 − γ − λ) · F(β · (t(x) − t(α)))

α is the threshold, β the slope (spread) parameter, γ the guess rate (fixed by the design: 0 for
yes/no, 1/n for nAFC), λ the lapse rate. F and t per family:

| family   | F(z)                 | t(x)  | F at the threshold |
|----------|----------------------|-------|--------------------|
| logistic | 1 / (1 + e^−z)       | x     | 0.5                |
| normal   | Φ(z)                 | x     | 0.5                |
| gumbel   | 1 − exp(−e^z)        | x     | 1 − 1/e ≈ 0.632    |
| weibull  | 1 − exp(−e^z)        | ln x  | 1 − 1/e ≈ 0.632    |

so Weibull is Gumbel on ln x: 1 − exp(−(x/α)^β) (Wichmann & Hill 2001, P&P 63:1293). Gumbel is
what the Weibull becomes when x is already logarithmic (dB). Every fit works on the linear
predictor z = b0 + b1·t(x) (b1 = β, b0 = −β·t(α)), the GLM's, so the logistic and normal fits with
γ = λ = 0 are the logit and probit binomial GLMs.

numpy only, so the procedures (QUEST+'s likelihood table) run on a server without the analysis
extra: Φ comes from scipy.special.ndtr when scipy is there and from math.erf otherwise (both
correct to double precision; scipy's is vectorised, which the fits' bootstrap needs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

try:  # the analysis extra; the fallback gives the same numbers, only slower
    from scipy.special import ndtr as _ndtr
except ImportError:  # pragma: no cover - exercised by the no-scipy test in a subprocess
    _erf = np.frompyfunc(math.erf, 1, 1)

    def _ndtr(z):
        z = np.asarray(z, dtype=float)
        return 0.5 * (1.0 + _erf(z / math.sqrt(2.0)).astype(float))


def _logistic(z):
    z = np.asarray(z, dtype=float)
    return 0.5 * (1.0 + np.tanh(0.5 * z))  # = 1/(1+e^−z) without overflow


def _logistic_density(z):
    f = _logistic(z)
    return f * (1.0 - f)


def _normal_density(z):
    z = np.asarray(z, dtype=float)
    return np.exp(-0.5 * z * z) / math.sqrt(2.0 * math.pi)


def _gumbel(z):
    z = np.minimum(np.asarray(z, dtype=float), 700.0)
    return -np.expm1(-np.exp(z))


def _gumbel_density(z):
    z = np.minimum(np.asarray(z, dtype=float), 700.0)
    e = np.exp(z)
    return e * np.exp(-e)


def _identity(x):
    return np.asarray(x, dtype=float)


def _log(x):
    x = np.asarray(x, dtype=float)
    with np.errstate(divide="ignore"):
        return np.log(np.maximum(x, 0.0))  # x ≤ 0 → −inf → F = 0: below any Weibull's range


@dataclass(frozen=True)
class Family:
    """A psychometric family: its sigmoid F(z), F's density, and the transform t of the level."""
    name: str
    sigmoid: Callable
    density: Callable
    transform: Callable
    at_threshold: float  # F(0): the share of the way from γ to 1 − λ reached at the threshold

    def core(self, x, threshold, slope):
        """F(β·(t(x) − t(α))), broadcast over the arguments."""
        return self.sigmoid(np.asarray(slope) * (self.transform(x) - self.transform(threshold)))

    def probability(self, x, threshold, slope, guess=0.0, lapse=0.0):
        """p(x) = γ + (1 − γ − λ)·F: the probability of a correct (or "yes") answer."""
        guess = np.asarray(guess, dtype=float)
        return guess + (1.0 - guess - np.asarray(lapse, dtype=float)) * self.core(x, threshold, slope)

    def level_at(self, p, threshold, slope, guess=0.0, lapse=0.0):
        """The level x where p(x) = p (the inverse; p strictly between γ and 1 − λ)."""
        f = (np.asarray(p, dtype=float) - guess) / (1.0 - guess - lapse)
        if self.sigmoid is _gumbel:
            z = np.log(-np.log1p(-f))
        elif self.sigmoid is _logistic:
            z = np.log(f / (1.0 - f))
        else:
            z = _normal_quantile(f)
        t = self.transform(threshold) + z / np.asarray(slope, dtype=float)
        return np.exp(t) if self.transform is _log else t


def _normal_quantile(f):
    """Φ⁻¹ by bisection on Φ (numpy only; exact to ~1e-13, used only outside any hot path)."""
    f = np.asarray(f, dtype=float)
    lo, hi = np.full(f.shape, -40.0), np.full(f.shape, 40.0)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        below = _ndtr(mid) < f
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return 0.5 * (lo + hi)


LOGISTIC = Family("logistic", _logistic, _logistic_density, _identity, 0.5)
NORMAL = Family("normal", _ndtr, _normal_density, _identity, 0.5)
GUMBEL = Family("gumbel", _gumbel, _gumbel_density, _identity, 1.0 - math.exp(-1.0))
WEIBULL = Family("weibull", _gumbel, _gumbel_density, _log, 1.0 - math.exp(-1.0))

FAMILIES: dict[str, Family] = {f.name: f for f in (LOGISTIC, NORMAL, GUMBEL, WEIBULL)}
