"""QUEST+ (Watson 2017, J. Vision 17(3):10) on a numpy grid.

A posterior π over a grid of parameter vectors θ (any number of parameters) and a table of the
likelihoods L[r, x, θ] of each outcome r at each stimulus x (any number of stimulus dimensions,
flattened). The next stimulus minimises the expected entropy of the posterior after the trial
(the psi method's criterion: Kontsevich & Tyler 1999, Vision Res. 39:2729):

    E[H](x) = Σ_r Z_r(x)·H_r(x),  Z_r(x) = Σ_θ L[r,x,θ]·π(θ),  H_r = −Σ_θ q log q,  q = L·π / Z_r

which, with Σ_θ q log q expanded and Σ_r L = 1, is  Σ_r Z_r log Z_r − Σ_θ N·π − Σ_θ π log π,
N[x,θ] = Σ_r L log L. The last term is the same for every x, so the choice needs one matrix product
of a table computed once ([L without its last outcome; N], (R·X, Θ)) with π: on a 50×50×6 grid and
50 levels a few milliseconds (`viestac bench psychophysics`). Ties go to the first stimulus, so the
choice is a pure function of the answers. The estimate is the posterior mean or mode.

numpy only (no scipy): the procedures run on a server without the analysis extra.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np

from server.core.did_you_mean import did_you_mean
from server.psychophysics.functions import FAMILIES
from server.psychophysics.spec import Fields, SpecError

PSYCHOMETRIC_PARAMS = ("threshold", "slope", "guess", "lapse")


class QuestPlusGrid:
    """The fixed part: stimuli, parameters, the likelihood tables and the prior (built once)."""

    def __init__(self, likelihood: np.ndarray, stimuli: Mapping[str, np.ndarray], params: Mapping[str, np.ndarray],
                 prior: np.ndarray | None = None):
        L = np.asarray(likelihood, dtype=float)
        n_x, n_theta = len(next(iter(stimuli.values()))), len(next(iter(params.values())))
        if L.ndim != 3 or L.shape[1:] != (n_x, n_theta):
            raise ValueError(f"likelihood must be (outcomes, {n_x} stimuli, {n_theta} parameter points), got {L.shape}")
        if not np.allclose(L.sum(axis=0), 1.0):
            raise ValueError("the outcomes' likelihoods must sum to 1 at every stimulus and parameter point")
        self.stimuli = {k: np.asarray(v, dtype=float) for k, v in stimuli.items()}
        self.params = {k: np.asarray(v, dtype=float) for k, v in params.items()}
        self.likelihood = L
        with np.errstate(divide="ignore", invalid="ignore"):
            n_table = np.where(L > 0, L * np.log(L), 0.0).sum(axis=0)
        # one (R·X, Θ) table: the outcomes but the last (it is 1 − their sum), then N
        self._table = np.ascontiguousarray(np.concatenate([L[:-1].reshape(-1, n_theta), n_table]))
        prior = np.ones(n_theta) if prior is None else np.asarray(prior, dtype=float)
        if prior.shape != (n_theta,) or np.any(prior < 0) or prior.sum() <= 0:
            raise ValueError("the prior must be non-negative weights, one per parameter point, not all 0")
        self.prior = prior / prior.sum()
        self.axes: dict[str, int] | None = None  # parameter → grid size, when θ is a full grid (from_model)
        self._marginal_tables: dict = {}

    def marginal_table(self, focus: tuple) -> tuple[np.ndarray, np.ndarray]:
        """For the psi-marginal choice: θ reordered so that the `focus` parameters' axes lead
        (a permutation of θ), and L without its last outcome on that order, (R − 1, X, G, K)."""
        if focus not in self._marginal_tables:
            if self.axes is None or not set(focus) <= set(self.axes):
                raise ValueError(f"a marginal choice needs a full parameter grid with {list(focus)}")
            names = list(self.axes)
            order = [names.index(n) for n in focus] + [i for i, n in enumerate(names) if n not in focus]
            perm = np.arange(len(self.prior)).reshape(tuple(self.axes.values())).transpose(order).ravel()
            groups = int(np.prod([self.axes[n] for n in focus]))
            L = self.likelihood[:-1][:, :, perm]
            self._marginal_tables[focus] = (perm, np.ascontiguousarray(L.reshape(L.shape[0], L.shape[1], groups, -1)))
        return self._marginal_tables[focus]

    @classmethod
    def from_model(cls, model: Callable, stimuli: Mapping[str, np.ndarray], params: Mapping[str, np.ndarray],
                   prior: np.ndarray | None = None) -> "QuestPlusGrid":
        """A binary task: `model(stim, theta)` gives p(correct) for dicts of broadcastable arrays.
        `stimuli` and `params` are grids per dimension; their outer products are formed here."""
        s_names, p_names = list(stimuli), list(params)
        s_mesh = np.meshgrid(*[np.asarray(stimuli[k], dtype=float) for k in s_names], indexing="ij")
        p_mesh = np.meshgrid(*[np.asarray(params[k], dtype=float) for k in p_names], indexing="ij")
        s_flat = {k: m.ravel() for k, m in zip(s_names, s_mesh)}
        p_flat = {k: m.ravel() for k, m in zip(p_names, p_mesh)}
        p = model({k: v[:, None] for k, v in s_flat.items()}, {k: v[None, :] for k, v in p_flat.items()})
        p = np.clip(np.broadcast_to(p, (len(s_flat[s_names[0]]), len(p_flat[p_names[0]]))), 0.0, 1.0)
        grid = cls(np.stack([1.0 - p, p]), s_flat, p_flat, prior)
        grid.axes = {k: len(np.asarray(params[k]).ravel()) for k in p_names}
        return grid


class QuestPlus:
    """The running posterior. `stimulus` is the next stimulus (a dict, None once finished),
    `update(outcome)` takes the answer to it (True/1: correct or yes)."""

    def __init__(self, grid: QuestPlusGrid, max_trials: int, estimate: str = "mean", focus: tuple = ()):
        self.grid, self.max_trials, self.estimator, self.focus = grid, max_trials, estimate, tuple(focus)
        if self.focus:
            grid.marginal_table(self.focus)  # built once per grid and focus, before the first choice
        self.posterior = grid.prior.copy()
        self.trial = 0
        self._next = self._choose()

    def expected_entropy(self) -> np.ndarray:
        """E[H] of the posterior after a trial at each stimulus, less Σ π log π (the same for all)."""
        r, x = self.grid.likelihood.shape[:2]
        # einsum, not @: a matrix-vector product through OpenBLAS spreads over threads that spin
        # against every other process on a small machine (p50 5 ms, p99 70 ms on 2 loaded cores,
        # against 0.6 ms and 13 ms for einsum's own loop, which runs in one thread)
        product = np.einsum("ij,j->i", self.grid._table, self.posterior)
        z = product[: (r - 1) * x].reshape(r - 1, x)
        z = np.concatenate([z, 1.0 - z.sum(axis=0, keepdims=True)])
        with np.errstate(divide="ignore", invalid="ignore"):
            z_log_z = np.where(z > 0, z * np.log(z), 0.0).sum(axis=0)
        return z_log_z - product[(r - 1) * x:]

    def expected_marginal_entropy(self) -> np.ndarray:
        """E[H] of the `focus` parameters' marginal posterior after a trial at each stimulus (the
        psi-marginal method, Prins 2013, J. Vision 13(7):3: the other parameters are nuisances,
        and no trial is spent on learning them for their own sake)."""
        perm, L = self.grid.marginal_table(self.focus)
        pi = self.posterior[perm].reshape(L.shape[2], L.shape[3])
        m = np.einsum("rxgk,gk->rxg", L, pi)                      # Σ over the nuisances of L·π
        last = np.maximum(pi.sum(axis=1)[None, :] - m.sum(axis=0), 0.0)
        m = np.concatenate([m, last[None]])
        z = m.sum(axis=2)
        with np.errstate(divide="ignore", invalid="ignore"):
            z_log_z = np.where(z > 0, z * np.log(z), 0.0).sum(axis=0)
            m_log_m = np.where(m > 0, m * np.log(m), 0.0).sum(axis=(0, 2))
        return z_log_z - m_log_m

    def _choose(self) -> int:
        return int(np.argmin(self.expected_marginal_entropy() if self.focus else self.expected_entropy()))

    @property
    def finished(self) -> bool:
        return self.trial >= self.max_trials

    @property
    def stimulus(self) -> dict | None:
        if self.finished:
            return None
        return {k: float(v[self._next]) for k, v in self.grid.stimuli.items()}

    @property
    def level(self) -> float | None:
        """The first stimulus dimension (the level, for a one-dimensional task)."""
        s = self.stimulus
        return None if s is None else next(iter(s.values()))

    def update(self, outcome) -> None:
        if self.finished:
            raise ValueError("QUEST+ has finished: no trial to answer")
        post = self.posterior * self.grid.likelihood[int(outcome), self._next]
        total = post.sum()
        # an answer the model calls impossible (p = 0 everywhere): keep the prior belief, not NaN
        self.posterior = post / total if total > 0 else self.posterior
        self.trial += 1
        self._next = self._choose()

    def estimates(self) -> dict:
        if self.estimator == "mode":
            i = int(np.argmax(self.posterior))
            return {k: float(v[i]) for k, v in self.grid.params.items()}
        return {k: float(self.posterior @ v) for k, v in self.grid.params.items()}

    def estimate(self) -> float:
        return next(iter(self.estimates().values()))

    def sd(self) -> dict:
        return {k: float(math.sqrt(max(self.posterior @ (v * v) - (self.posterior @ v) ** 2, 0.0)))
                for k, v in self.grid.params.items()}

    def record(self) -> dict:
        return {"trial": self.trial, "stimulus": self.stimulus, "finished": self.finished,
                "estimate": self.estimates(), "sd": self.sd()}


# --- the spec of a psychometric QUEST+ (one stimulus dimension: the level) ---------------------

def _grid(f: Fields, name: str, default=None):
    """A parameter or stimulus grid: a number (fixed), a list, or {from, to, count, spacing}."""
    value = f.table.get(name, default)
    f.read.add(name)
    if value is None:
        raise f.error(name, "missing (required)")
    if isinstance(value, Mapping):
        g = Fields(value, f"{f.where}: {name}")
        lo, hi = g.number("from"), g.number("to")
        count = int(g.number("count", low=2, whole=True))
        spacing = g.choice("spacing", ("linear", "log"), "linear")
        g.done()
        if lo >= hi:
            raise f.error(name, f"from {lo} must be below to {hi}")
        if spacing == "log":
            if lo <= 0:
                raise f.error(name, f"a log grid needs from > 0, got {lo}")
            return np.geomspace(lo, hi, count)
        return np.linspace(lo, hi, count)
    values = f.numbers(name, None)
    values = (float(default),) if values is None else values
    if len(set(values)) != len(values):
        raise f.error(name, f"a value appears twice: {list(values)}")
    return np.asarray(values, dtype=float)


@dataclass(frozen=True)
class QuestPlusSpec:
    family: str
    levels: tuple
    params: tuple          # ((name, values), ...) in PSYCHOMETRIC_PARAMS order
    priors: tuple          # ((name, mean, sd) | None, ...) normal priors, None: uniform
    max_trials: int
    estimate: str
    focus: tuple = ()      # the parameters whose marginal entropy the choice minimises (): all
    kind: str = "quest-plus"

    @classmethod
    def parse(cls, table, where: str = "procedure") -> "QuestPlusSpec":
        f = Fields(table, where)
        f.choice("kind", ("quest-plus",))
        family = f.choice("family", tuple(FAMILIES), "weibull")
        levels = _grid(f, "levels")
        if family == "weibull" and np.any(levels <= 0):
            raise f.error("levels", "a weibull family needs levels > 0")
        params, priors = [], []
        defaults = {"guess": 0.5, "lapse": 0.02}
        prior_table = f.table_of("prior", {})
        for name in PSYCHOMETRIC_PARAMS:
            values = _grid(f, name, defaults.get(name))
            if name in ("guess", "lapse") and (np.any(values < 0) or np.any(values >= 1)):
                raise f.error(name, f"must lie in [0, 1), got {values.tolist()}")
            if name == "slope" and np.any(values <= 0):
                raise f.error(name, f"must be > 0, got {values.tolist()}")
            params.append((name, tuple(values.tolist())))
        if any(g + lp >= 1 for g in dict(params)["guess"] for lp in dict(params)["lapse"]):
            raise f.error("lapse", "guess + lapse must stay below 1")
        p = Fields(prior_table, f"{where}: prior")
        for name in PSYCHOMETRIC_PARAMS:
            normal = p.numbers(name, None, min_len=2)
            if normal is not None and (len(normal) != 2 or normal[1] <= 0):
                raise p.error(name, f"a normal prior is [mean, sd > 0], got {list(normal)}")
            priors.append(None if normal is None else (name, *normal))
        p.done()
        max_trials = int(f.number("max_trials", low=1, whole=True))
        estimate = f.choice("estimate", ("mean", "mode"), "mean")
        focus = f.table.get("focus", [])
        f.read.add("focus")
        if isinstance(focus, str):
            focus = [focus]
        if not isinstance(focus, (list, tuple)):
            raise f.error("focus", f"expected a list of parameter names, got {focus!r}")
        for name in focus:
            if name not in PSYCHOMETRIC_PARAMS:
                raise f.error("focus", f"unknown parameter {name!r}{did_you_mean(str(name), PSYCHOMETRIC_PARAMS)}")
            if len(dict(params)[name]) < 2:
                raise f.error("focus", f"{name} is fixed ({dict(params)[name][0]}): nothing to learn about it")
        f.done()
        return cls(family, tuple(levels.tolist()), tuple(params), tuple(priors), max_trials, estimate,
                   tuple(n for n in PSYCHOMETRIC_PARAMS if n in focus))

    def grid(self) -> QuestPlusGrid:
        family = FAMILIES[self.family]
        params = {k: np.asarray(v) for k, v in self.params}

        def model(stim, th):
            return family.probability(stim["level"], th["threshold"], th["slope"], th["guess"], th["lapse"])

        grid = QuestPlusGrid.from_model(model, {"level": np.asarray(self.levels)}, params)
        prior = np.ones(len(grid.prior))
        for entry in self.priors:
            if entry is not None:
                name, mean, sd = entry
                prior *= np.exp(-0.5 * ((grid.params[name] - mean) / sd) ** 2)
        if prior.sum() <= 0:
            raise SpecError("prior: the normal priors leave no weight on the grid")
        grid.prior = prior / prior.sum()
        return grid


@functools.lru_cache(maxsize=8)
def _grid_of(spec: QuestPlusSpec) -> QuestPlusGrid:
    return spec.grid()  # read-only once built: a replay from the answers need not build it again


def quest_plus(spec: QuestPlusSpec, seed=0) -> QuestPlus:
    """A QUEST+ from its spec (deterministic: `seed` is unused)."""
    return QuestPlus(_grid_of(spec), spec.max_trials, spec.estimate, spec.focus)
