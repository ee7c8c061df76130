"""Task 3, stiffness magnitude estimation and production (thesis §5.4.3; docs/analysis.md).

Estimation: params.level (the middle sphere) against the named level (answer_level). Production:
params.level (the target) against the level the participant produced (metrics.produced_level).
Per level: the mean response with a t-based 95 % CI. Stevens' power law p = a·S^b is fitted to
the trials at levels 2..9 only, as the thesis did (levels 1 and 10 are the reference spheres
themselves), by ordinary least squares on log-log axes (statsmodels): ln p = ln a + b·ln S, so b is
the slope and a = e^intercept. That is the usual psychophysics fit (multiplicative error); with
every level equally often it equals the fit through the per-level geometric means. A non-linear
least-squares fit (scipy.optimize.curve_fit, additive error) is reported beside it as a check.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from server.analysis.load import answered, number
from server.analysis.stats import Skip, describe_by, guarded, num, quiet

SCENARIO = "stiffness"
FIT_LEVELS = tuple(range(2, 10))   # thesis §5.4.3: "values only between 2-9 were considered"
FIT_METHOD = "log-log OLS (statsmodels): ln p = ln a + b ln S"
COLUMNS = ("trial_id", "participant", "level", "response", "match_time_s")


def _mode(t) -> str | None:
    mode = t.params.get("mode")
    if mode in ("estimation", "production"):
        return mode
    if "answer_level" in t.responses:   # a study that omits the mode: tell them apart by what was recorded
        return "estimation"
    return "production" if "produced_level" in t.metrics else None


def select(trials: pd.DataFrame, mode: str) -> pd.DataFrame:
    """Main trials of one mode: (level, response) with the named level (estimation) or the
    produced level (production)."""
    rows = []
    for t in answered(trials, SCENARIO).itertuples():
        if _mode(t) != mode:
            continue
        level = number(t.params.get("level"))
        if level is None:
            level = number(t.metrics.get("target_level"))
        if mode == "estimation":
            response, match = number(t.responses.get("answer_level")), None
        else:
            response, match = number(t.metrics.get("produced_level")), number(t.metrics.get("match_time_s"))
        if level is not None and response is not None:
            rows.append((t.trial_id, t.participant, level, response, match))
    return pd.DataFrame(rows, columns=COLUMNS)


def analyze(estimation: pd.DataFrame, production: pd.DataFrame) -> tuple[dict, dict]:
    """stats.json's `task3` section and its skipped analyses."""
    skipped: dict[str, str] = {}
    section = {"fit_method": FIT_METHOD, "fit_levels": list(FIT_LEVELS)}
    for mode, frame in (("estimation", estimation), ("production", production)):
        part = {"n_trials": int(len(frame)), "n_participants": int(frame["participant"].nunique())}
        if frame.empty:
            reason = f"no answered stiffness {mode} main trials"
            part.update(per_level=None, a=None, b=None, fit=None)
            skipped.update({f"{mode}.per_level": reason, f"{mode}.fit": reason})
        else:
            part["per_level"] = describe_by(frame, "response", ["level"])
            if mode == "production" and frame["match_time_s"].notna().any():
                times = {r["level"]: r for r in describe_by(frame, "match_time_s", ["level"])}
                for row in part["per_level"]:
                    row["match_time_s_mean"] = (times.get(row["level"]) or {}).get("mean")
            part["fit"] = guarded(skipped, f"{mode}.fit", power_fit, frame)
            part["a"] = part["fit"]["a"] if part["fit"] else None
            part["b"] = part["fit"]["b"] if part["fit"] else None
        if part["fit"] is None:  # a and b are what readers look up: they carry the reason too
            skipped[f"{mode}.a"] = skipped[f"{mode}.b"] = skipped[f"{mode}.fit"]
        section[mode] = part
    return section, skipped


def power_fit(frame: pd.DataFrame, levels: tuple[int, ...] = FIT_LEVELS) -> dict:
    """p = a·S^b by log-log OLS on the trials at `levels` with positive responses; the NLS fit
    (curve_fit) beside it."""
    import statsmodels.api as sm
    from scipy.optimize import curve_fit

    rows = frame[frame["level"].isin(levels) & (frame["response"] > 0) & (frame["level"] > 0)]
    if rows["level"].nunique() < 2 or len(rows) < 3:
        raise Skip(f"needs trials at 2 or more of the levels {levels[0]}..{levels[-1]} (at least 3 trials), "
                   f"got {rows['level'].nunique()} levels and {len(rows)} trials")
    s, p = rows["level"].to_numpy(float), rows["response"].to_numpy(float)
    with quiet():  # noiseless data: R² = 1 and zero standard errors are fine
        fit = sm.OLS(np.log(p), sm.add_constant(np.log(s), has_constant="add")).fit()
        ci = fit.conf_int(alpha=0.05)
    out = {"method": FIT_METHOD, "levels": [int(v) for v in sorted(rows["level"].unique())], "n": int(fit.nobs),
           "n_participants": int(rows["participant"].nunique()),
           "a": num(np.exp(fit.params[0])), "b": num(fit.params[1]), "se_b": num(fit.bse[1]),
           "a_ci95": [num(np.exp(ci[0][0])), num(np.exp(ci[0][1]))], "b_ci95": [num(ci[1][0]), num(ci[1][1])],
           "r2_log": num(fit.rsquared), "p_b": num(fit.pvalues[1]), "nls": None}
    try:
        with quiet():
            (a, b), cov = curve_fit(lambda x, a, b: a * np.power(x, b), s, p, p0=(out["a"], out["b"]),
                                    maxfev=10_000)
            se = np.sqrt(np.diag(cov))
        out["nls"] = {"method": "non-linear least squares (scipy.optimize.curve_fit): p = a·S^b + e",
                      "a": num(a), "b": num(b), "se_a": num(se[0]), "se_b": num(se[1])}
    except (RuntimeError, ValueError):  # no convergence: the main fit stands alone
        pass
    return out
