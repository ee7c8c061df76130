"""Task 1, contact angle discrimination (thesis §5.2.3; docs/analysis.md).

Per trial the absolute deviation |answer − angle| (degrees). Per angle: mean absolute deviation
with a t-based 95 % CI over the participants; a one-way repeated-measures ANOVA of the deviation
over the angles with the Greenhouse-Geisser correction (pingouin); and the quadratic trend, an OLS
regression of the deviation on angle and angle² over all trials (statsmodels), which is how the
thesis tested the U shape (its F(1, 126) is the quadratic term's test).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from server.analysis.load import answered, number
from server.analysis.stats import Skip, describe, describe_by, guarded, num, quiet, rm_anova

SCENARIO = "contact-angle"
COLUMNS = ("trial_id", "participant", "angle", "answer", "abs_dev", "signed_error")


def select(trials: pd.DataFrame) -> pd.DataFrame:
    """Main trials with a presented angle (params.angle_deg) and a numeric answer (answer_deg)."""
    rows = []
    for t in answered(trials, SCENARIO).itertuples():
        angle, answer = number(t.params.get("angle_deg")), number(t.responses.get("answer_deg"))
        if angle is not None and answer is not None:
            rows.append((t.trial_id, t.participant, angle, answer, abs(answer - angle), answer - angle))
    return pd.DataFrame(rows, columns=COLUMNS)


def analyze(frame: pd.DataFrame) -> tuple[dict, dict]:
    """stats.json's `task1` section and its skipped analyses (relative paths → reasons)."""
    skipped: dict[str, str] = {}
    section = {"n_trials": int(len(frame)), "n_participants": int(frame["participant"].nunique())}
    if frame.empty:
        for key in ("per_angle", "mean_abs_dev", "rm_anova", "quadratic_trend"):
            section[key] = None
            skipped[key] = "no answered contact-angle main trials (params.angle_deg with an answer_deg)"
        return section, skipped
    per_angle = describe_by(frame, "abs_dev", ["angle"])
    bias = frame.groupby("angle")["signed_error"].mean()
    for row in per_angle:
        row["mean_signed_error"] = num(bias[row["angle"]])
    section["per_angle"] = per_angle
    section["mean_abs_dev"] = describe(frame, "abs_dev")
    section["rm_anova"] = guarded(skipped, "rm_anova", rm_anova, frame, "abs_dev", "angle")
    section["quadratic_trend"] = guarded(skipped, "quadratic_trend", quadratic_trend, frame)
    return section, skipped


def quadratic_trend(frame: pd.DataFrame) -> dict:
    """OLS abs_dev = b0 + b1·angle + b2·angle² (statsmodels), every trial one observation."""
    import statsmodels.api as sm

    if len(frame) < 4 or frame["angle"].nunique() < 3:
        raise Skip(f"needs at least 3 angles and 4 trials, got {frame['angle'].nunique()} and {len(frame)}")
    x = frame["angle"].to_numpy(float)
    design = sm.add_constant(np.column_stack([x, x ** 2]), has_constant="add")
    with quiet():  # constant deviations: R² and F are undefined (NaN → null), not an error
        fit = sm.OLS(frame["abs_dev"].to_numpy(float), design).fit()
        quad = fit.f_test(np.array([[0.0, 0.0, 1.0]]))  # the quadratic term alone: the thesis's F(1, n−3)
        return {"b0": num(fit.params[0]), "b1": num(fit.params[1]), "b2": num(fit.params[2]),
                "se_b0": num(fit.bse[0]), "se_b1": num(fit.bse[1]), "se_b2": num(fit.bse[2]),
                "p_b0": num(fit.pvalues[0]), "p_b1": num(fit.pvalues[1]), "p_b2": num(fit.pvalues[2]),
                "F_quadratic": num(np.squeeze(quad.fvalue)), "df_quadratic": [num(quad.df_num), num(quad.df_denom)],
                "p_quadratic": num(np.squeeze(quad.pvalue)),
                "F_model": num(fit.fvalue), "p_model": num(fit.f_pvalue), "df_model": [num(fit.df_model),
                                                                                      num(fit.df_resid)],
                "r2": num(fit.rsquared), "n": int(fit.nobs)}
