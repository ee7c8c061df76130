"""Maximum-likelihood psychometric fits and their parametric bootstrap (Wichmann & Hill 2001,
P&P 63:1293 and 1314).

The model is functions.py's, p = γ + (1 − γ − λ)·F(z), z = b0 + b1·t(x): the guess rate γ is fixed
by the design, the lapse rate λ fitted within [0, lapse_max] (λ = lapse_max·σ(u), so the bound
holds without a constrained optimiser; lapse_max = 0 fixes λ = 0). The binomial log-likelihood
is maximised by Fisher scoring with step halving, vectorised over many data sets at once, so the
parametric bootstrap (refit every resampled data set) of hundreds of data sets runs in seconds.
With γ = λ = 0 Fisher scoring is the binomial GLM's IRLS (logit: logistic, probit: normal), and the
fit equals statsmodels' to 1e-6 (tests/psychophysics/test_fit.py).

threshold α: z = 0, i.e. −b0/b1 (weibull: exp(−b0/b1)); slope β = b1. The slope is kept within
[1e-3, 1e3] / (the span of t(x)), so data a step function fits perfectly (separation) stop at the
bound instead of running off.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from server.psychophysics.functions import FAMILIES, Family

_EPS = 1e-12


@dataclass(frozen=True)
class Fit:
    family: str
    guess: float
    threshold: float
    slope: float
    lapse: float
    deviance: float
    log_likelihood: float
    converged: bool

    def probability(self, x):
        return FAMILIES[self.family].probability(x, self.threshold, self.slope, self.guess, self.lapse)


@dataclass(frozen=True)
class Bootstrap:
    threshold_ci: tuple[float, float]
    slope_ci: tuple[float, float]
    deviance_p: float        # share of the resampled deviances at least the observed one
    samples: int
    thresholds: np.ndarray
    slopes: np.ndarray


def _check(levels, n, k):
    levels = np.asarray(levels, dtype=float)
    n, k = np.asarray(n, dtype=float), np.asarray(k, dtype=float)
    if levels.ndim != 1 or n.shape != levels.shape or k.shape[-1:] != levels.shape:
        raise ValueError("levels, n and k need one entry per level")
    if np.any(n <= 0) or np.any(k < 0) or np.any(k > n):
        raise ValueError("every level needs n > 0 trials and 0 ≤ k ≤ n correct")
    if len(np.unique(levels)) < 2:
        raise ValueError("a fit needs at least two distinct levels")
    return levels, n, k


def _sigma(u):
    return 0.5 * (1.0 + np.tanh(0.5 * u))


def _probability(family: Family, t, b0, b1, lapse, guess):
    z = b0[:, None] + b1[:, None] * t[None, :]
    F, f = family.sigmoid(z), family.density(z)
    scale = (1.0 - guess - lapse)[:, None]
    return np.clip(guess + scale * F, _EPS, 1.0 - _EPS), F, f, scale


def _log_likelihood(p, n, k):
    return np.sum(k * np.log(p) + (n - k) * np.log1p(-p), axis=-1)


def _deviance(p, n, k):
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(k > 0, k * np.log(k / (n * p)), 0.0)
        b = np.where(n - k > 0, (n - k) * np.log((n - k) / (n * (1.0 - p))), 0.0)
    return 2.0 * np.sum(a + b, axis=-1)


def fit_many(levels, n, k, family: str = "logistic", guess: float = 0.0, lapse_max: float = 0.06,
             iterations: int = 100):
    """Fit every row of k (data sets × levels, same levels and n) at once; arrays of threshold,
    slope, lapse, deviance, log-likelihood and converged."""
    fam = FAMILIES[family]
    levels, n, k = _check(levels, n, k)
    k = np.atleast_2d(k)
    if not 0 <= guess < 1 or not 0 <= lapse_max < 1 - guess:
        raise ValueError(f"need 0 ≤ guess < 1 and 0 ≤ lapse_max < 1 − guess, got {guess}, {lapse_max}")
    if family == "weibull" and np.any(levels <= 0):
        raise ValueError("a weibull fit needs levels > 0")
    t = fam.transform(levels)
    span = float(t.max() - t.min())
    b1_lo, b1_hi = 1e-3 / span, 1e3 / span
    with_lapse = lapse_max > 0
    B = k.shape[0]

    def lapse_of(u):
        return lapse_max * _sigma(u) if with_lapse else np.zeros_like(u)

    # start: the best point of a coarse grid (threshold across the levels, slope over 2 decades)
    a_grid = np.linspace(t.min(), t.max(), 15)
    s_grid = np.geomspace(0.5, 50.0, 12) / span
    A, S = (g.ravel() for g in np.meshgrid(a_grid, s_grid, indexing="ij"))
    lapse0 = min(0.01, lapse_max / 2)
    u0 = np.log(lapse0 / (lapse_max - lapse0)) if with_lapse else 0.0
    p0, *_ = _probability(fam, t, -S * A, S, np.full(len(A), lapse0 if with_lapse else 0.0), guess)
    ll0 = k @ np.log(p0).T + (n - k) @ np.log1p(-p0).T          # (B, grid)
    best = np.argmax(ll0, axis=1)
    theta = np.stack([-S[best] * A[best], S[best], np.full(B, u0)], axis=1)
    dims = 3 if with_lapse else 2

    def evaluate(th):
        lapse = lapse_of(th[:, 2])
        p, F, f, scale = _probability(fam, t, th[:, 0], th[:, 1], lapse, guess)
        return p, F, f, scale, lapse

    p, F, f, scale, lapse = evaluate(theta)
    ll = _log_likelihood(p, n, k)
    converged = np.zeros(B, dtype=bool)
    for _ in range(iterations):
        d0 = scale * f
        grads = [d0, d0 * t[None, :]]
        if with_lapse:
            s = _sigma(theta[:, 2])
            grads.append(-F * (lapse_max * s * (1.0 - s))[:, None])
        D = np.stack(grads, axis=-1)                                    # (B, L, dims)
        w = 1.0 / (p * (1.0 - p))
        score = np.einsum("bl,bld->bd", (k - n * p) * w, D)
        info = np.einsum("bl,bld,ble->bde", n * w, D, D) + 1e-12 * np.eye(dims)
        step = np.linalg.solve(info, score[..., None])[..., 0]
        step = np.where(converged[:, None], 0.0, step)
        full = np.zeros_like(theta)
        full[:, :dims] = step
        factor = np.ones(B)
        accepted = np.zeros(B, dtype=bool)
        new_theta, new_ll = theta, ll
        for _ in range(30):  # halve until the likelihood does not fall
            trial = theta + factor[:, None] * full
            trial[:, 1] = np.clip(trial[:, 1], b1_lo, b1_hi)
            tp, *_ = evaluate(trial)
            tll = _log_likelihood(tp, n, k)
            ok = (tll >= ll - 1e-12 * np.abs(ll)) & ~accepted
            new_theta = np.where(ok[:, None], trial, new_theta)
            new_ll = np.where(ok, tll, new_ll)
            accepted |= ok
            if accepted.all():
                break
            factor = np.where(accepted, factor, factor / 2)
        moved = np.abs(new_theta - theta).max(axis=1)
        theta, ll = new_theta, new_ll
        converged |= (moved < 1e-10 * (1.0 + np.abs(theta).max(axis=1))) | ~accepted
        p, F, f, scale, lapse = evaluate(theta)
        if converged.all():
            break
    b0, b1 = theta[:, 0], theta[:, 1]
    threshold = -b0 / b1
    if fam.transform is not FAMILIES["logistic"].transform:
        threshold = np.exp(threshold)
    return {"threshold": threshold, "slope": b1, "lapse": lapse, "deviance": _deviance(p, n, k),
            "log_likelihood": ll, "converged": converged}


def fit(levels, n, k, family: str = "logistic", guess: float = 0.0, lapse_max: float = 0.06) -> Fit:
    """The maximum-likelihood fit of one data set: k correct of n trials at each level."""
    r = fit_many(levels, n, np.asarray(k, dtype=float)[None, :], family, guess, lapse_max)
    return Fit(family, guess, float(r["threshold"][0]), float(r["slope"][0]), float(r["lapse"][0]),
               float(r["deviance"][0]), float(r["log_likelihood"][0]), bool(r["converged"][0]))


def bootstrap(result: Fit, levels, n, rng: np.random.Generator, samples: int = 1000, lapse_max: float = 0.06,
              level: float = 0.95, observed_deviance: float | None = None) -> Bootstrap:
    """Parametric bootstrap: data sets drawn from the fitted function at the same levels and
    trial counts, each refitted; percentile intervals of threshold and slope, and the deviance's
    p (the share of resampled deviances ≥ the observed one)."""
    levels = np.asarray(levels, dtype=float)
    n = np.asarray(n)
    p = result.probability(levels)
    k = rng.binomial(n.astype(np.int64), p, size=(samples, len(levels))).astype(float)
    r = fit_many(levels, n, k, result.family, result.guess, lapse_max)
    tail = (1.0 - level) / 2.0 * 100.0
    th = np.percentile(r["threshold"], [tail, 100.0 - tail])
    sl = np.percentile(r["slope"], [tail, 100.0 - tail])
    dev = result.deviance if observed_deviance is None else observed_deviance
    return Bootstrap((float(th[0]), float(th[1])), (float(sl[0]), float(sl[1])),
                     float(np.mean(r["deviance"] >= dev)), samples, r["threshold"], r["slope"])
