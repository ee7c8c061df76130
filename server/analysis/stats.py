"""Thin wrappers around the statistics libraries, shared by the task modules.

Every number here comes from a library call (statsmodels, pingouin 0.7, scipy); these wrappers
only prepare the data (per-participant cells, complete cases), pick the result's fields, name them
the way stats.json does, and turn "too few data" into `Skip` with a reason instead of NaN.
"""

from __future__ import annotations

import math
import warnings
from contextlib import contextmanager
from typing import Any, Callable, Iterator

import numpy as np
import pandas as pd

CONFIDENCE = 0.95
MIN_SUBJECTS = 2  # a repeated-measures test needs at least two complete participants


class Skip(Exception):
    """An analysis that cannot run on these data; the message says why (stats.json, report)."""


def guarded(skipped: dict, path: str, fn: Callable, *args, **kwargs) -> Any:
    """fn(*args) or, when it raises Skip, None with the reason recorded under `path`."""
    try:
        return fn(*args, **kwargs)
    except Skip as exc:
        skipped[path] = str(exc)
        return None


@contextmanager
def quiet() -> Iterator[None]:
    """Silence the libraries' warnings about degenerate input and their own deprecations (pingouin
    0.7 on pandas 3): degenerate results come back as NaN, and num() turns those into null."""
    with warnings.catch_warnings():
        for category in (RuntimeWarning, DeprecationWarning, FutureWarning, UserWarning):
            warnings.simplefilter("ignore", category)
        yield


def num(value: Any) -> float | int | None:
    """A JSON-safe number: numpy scalars become Python ones, NaN and infinities None."""
    if value is None:
        return None
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    value = float(value)
    return value if math.isfinite(value) else None


def t_interval(values) -> tuple[float | None, float | None]:
    """95 % t-based confidence interval of the mean (statsmodels DescrStatsW.tconfint_mean):
    mean ± t(0.975, n−1)·s/√n. None below two values or without variance information."""
    from statsmodels.stats.weightstats import DescrStatsW

    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    if len(x) < 2:
        return None, None
    with quiet():
        low, high = DescrStatsW(x).tconfint_mean(alpha=1 - CONFIDENCE)
    return num(low), num(high)


def describe(frame: pd.DataFrame, value: str, subject: str = "participant") -> dict:
    """n, mean and SD over the rows (trials), and the 95 % CI over the participants' means
    (the participant is the unit of replication; with one trial per participant and cell, as in
    the thesis's designs, both are the same sample)."""
    rows = frame[[subject, value]].dropna()
    x = rows[value].astype(float)
    means = rows.groupby(subject, sort=True)[value].mean()
    low, high = t_interval(means.to_numpy())
    return {"n_trials": int(len(x)), "n_participants": int(means.size),
            "mean": num(x.mean()) if len(x) else None,
            "sd": num(x.std(ddof=1)) if len(x) > 1 else None,
            "ci95_low": low, "ci95_high": high}


def describe_by(frame: pd.DataFrame, value: str, by: list[str], subject: str = "participant") -> list[dict]:
    """`describe` per group, groups in sorted order, each row led by its group values."""
    out = []
    for key, group in frame.groupby(by, sort=True):
        key = key if isinstance(key, tuple) else (key,)
        out.append({**{b: _plain(k) for b, k in zip(by, key)}, **describe(group, value, subject)})
    return out


def _plain(value: Any) -> Any:
    return num(value) if isinstance(value, (int, float, np.integer, np.floating)) else value


def complete_cells(frame: pd.DataFrame, dv: str, within: list[str], subject: str) -> tuple[pd.DataFrame, int]:
    """Per participant and cell, the mean of `dv`; only participants with every cell (complete
    cases, as pingouin and SPSS do). Returns the cells and how many participants were dropped."""
    rows = frame[[subject, *within, dv]].dropna()
    cells = rows.groupby([subject, *within], sort=True, observed=True)[dv].mean().reset_index()
    n_cells = int(np.prod([rows[w].nunique() for w in within])) if len(rows) else 0
    counts = cells.groupby(subject)[dv].count()
    keep = counts[counts == n_cells].index
    return cells[cells[subject].isin(keep)], int(counts.size - keep.size)


def rm_anova(frame: pd.DataFrame, dv: str, within: str | list[str], subject: str = "participant") -> dict:
    """Repeated-measures ANOVA (pingouin.rm_anova, correction=True) on the per-participant cell
    means; one- or two-way. Greenhouse-Geisser: `eps`, `p_gg` (pingouin's p_GG_corr; with two
    levels sphericity holds trivially and p_gg = p_unc), and the corrected degrees of freedom."""
    import pingouin as pg

    within = [within] if isinstance(within, str) else list(within)
    levels = {w: frame[w].dropna().nunique() for w in within}
    if any(n < 2 for n in levels.values()):
        raise Skip(f"needs at least two levels of {' and '.join(within)}, got {levels}")
    cells, dropped = complete_cells(frame, dv, within, subject)
    n = int(cells[subject].nunique())
    if n < MIN_SUBJECTS:
        raise Skip(f"needs at least {MIN_SUBJECTS} participants with every {' × '.join(within)} cell, got {n}"
                   + (f" ({dropped} incomplete dropped)" if dropped else ""))
    if cells[dv].nunique() < 2:
        raise Skip(f"{dv} does not vary")
    try:
        with quiet():
            table = pg.rm_anova(data=cells, dv=dv, within=within if len(within) > 1 else within[0],
                                subject=subject, correction=True, detailed=False)
    except ZeroDivisionError:  # pingouin's sphericity test on a singular covariance (few participants)
        raise Skip(f"the sphericity test cannot be computed on these {n} participants' cells "
                   f"(a singular covariance)") from None
    effects = []
    for row in table.to_dict("records"):
        if row["Source"] == "Error":
            continue
        eps = num(row.get("eps"))
        p_unc = num(row.get("p_unc"))
        p_gg = num(row.get("p_GG_corr", p_unc))  # absent for two levels: no correction to make
        if num(row.get("F")) is None:
            raise Skip(f"the F ratio of {dv} is undefined (no residual variance within participants)")
        effects.append({"source": str(row["Source"]), "F": num(row["F"]), "ddof1": num(row["ddof1"]),
                        "ddof2": num(row["ddof2"]), "p_unc": p_unc, "eps": eps, "p_gg": p_gg,
                        "ddof1_gg": num(row["ddof1"] * eps) if eps is not None else None,
                        "ddof2_gg": num(row["ddof2"] * eps) if eps is not None else None,
                        "ng2": num(row.get("ng2")),
                        # Mauchly's W needs more participants than levels; pingouin returns a degenerate W otherwise
                        "sphericity_W": num(row.get("W_spher")) if n > max(levels.values()) else None,
                        "sphericity_p": num(row.get("p_spher")) if n > max(levels.values()) else None})
    out = {"within": within, "n_participants": n, "n_dropped_incomplete": dropped, "effects": effects}
    if len(effects) == 1:
        out.update({k: v for k, v in effects[0].items() if k != "source"})  # one-way: flat keys (task1.rm_anova.p_gg)
    return out


def anova_text(r: dict | None) -> str:
    """APA-style one-liner of a one-way result: F(3.4, 38.9) = 1.57, p = .18 (GG)."""
    if not r or r.get("F") is None:
        return "—"
    d1, d2 = r.get("ddof1_gg") or r["ddof1"], r.get("ddof2_gg") or r["ddof2"]
    return f"F({d1:.3g}, {d2:.3g}) = {r['F']:.2f}, {p_text(r['p_gg'])} (Greenhouse-Geisser ε = {r['eps']:.2f})"


def p_text(p: float | None) -> str:
    if p is None:
        return "p = n/a"
    return "p < .001" if p < 0.001 else f"p = {p:.3f}".replace("0.", ".", 1)
