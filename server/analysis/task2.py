"""Task 2, texture discrimination (thesis §5.3.3; docs/analysis.md).

Sub-task A (pairs: params.second_period_us present, Likert rating 1..7 "second vs first"): mean
rating per comparison with a t-based 95 % CI; a one-way repeated-measures ANOVA over the
comparisons with the Greenhouse-Geisser correction; Bonferroni-corrected paired t-tests
(pingouin.pairwise_tests, padjust="bonf") of every comparison against the reference comparison
(the pair whose two textures are the same, 250 vs 250 Hz in the thesis).

Sub-task B (identification: params.period_us, answer_hz): the actual × detected cross table
(pandas.crosstab) and Kendall's tau-b between actual and detected frequency
(scipy.stats.kendalltau, variant="b": the table is square, both axes are the same five
frequencies).
"""

from __future__ import annotations

import pandas as pd

from server.analysis.load import answered, number
from server.analysis.stats import MIN_SUBJECTS, Skip, complete_cells, describe, guarded, num, quiet, rm_anova

SCENARIO = "texture"
PAIR_COLUMNS = ("trial_id", "participant", "first_hz", "second_hz", "comparison", "rating")
IDENT_COLUMNS = ("trial_id", "participant", "actual_hz", "detected_hz")


def hz(period_us: float) -> float:
    """The frequency of a texture period as the study names it (two decimals: 333.33 Hz)."""
    return round(1e6 / period_us, 2)


def label(second_hz: float, first_hz: float) -> str:
    return f"{second_hz:g} vs {first_hz:g} Hz"


def select_pairs(trials: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for t in answered(trials, SCENARIO).itertuples():
        first, second = number(t.params.get("period_us")), number(t.params.get("second_period_us"))
        rating = number(t.responses.get("rating"))
        if first and second and rating is not None:
            rows.append((t.trial_id, t.participant, hz(first), hz(second), label(hz(second), hz(first)), rating))
    return pd.DataFrame(rows, columns=PAIR_COLUMNS)


def select_identification(trials: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for t in answered(trials, SCENARIO).itertuples():
        period, detected = number(t.params.get("period_us")), number(t.responses.get("answer_hz"))
        if period and t.params.get("second_period_us") is None and detected is not None:
            rows.append((t.trial_id, t.participant, hz(period), round(detected, 2)))
    return pd.DataFrame(rows, columns=IDENT_COLUMNS)


def analyze(pairs: pd.DataFrame, ident: pd.DataFrame) -> tuple[dict, dict]:
    """stats.json's `task2` section and its skipped analyses."""
    skipped: dict[str, str] = {}
    section: dict = {"pairs": {"n_trials": int(len(pairs)), "n_participants": int(pairs["participant"].nunique())},
                     "identification": {"n_trials": int(len(ident)),
                                        "n_participants": int(ident["participant"].nunique())}}
    p = section["pairs"]
    if pairs.empty:
        for key in ("per_comparison", "reference", "rm_anova", "posthoc"):
            p[key] = None
            skipped[f"pairs.{key}"] = "no answered texture pair trials (params.second_period_us with a rating)"
    else:
        order = pairs.sort_values(["second_hz", "first_hz"])["comparison"].drop_duplicates().tolist()
        p["per_comparison"] = [{"comparison": c, "first_hz": num(g["first_hz"].iloc[0]),
                                "second_hz": num(g["second_hz"].iloc[0]), **describe(g, "rating")}
                               for c in order for g in [pairs[pairs["comparison"] == c]]]
        same = [r["comparison"] for r in p["per_comparison"] if r["first_hz"] == r["second_hz"]]
        p["reference"] = same[0] if len(same) == 1 else None
        if p["reference"] is None:
            skipped["pairs.reference"] = f"needs exactly one same-texture comparison, found {len(same)}"
        p["rm_anova"] = guarded(skipped, "pairs.rm_anova", rm_anova, pairs, "rating", "comparison")
        p["posthoc"] = guarded(skipped, "pairs.posthoc", posthoc, pairs, p["reference"])
    ident_section = section["identification"]
    if ident.empty:
        ident_section["crosstab"] = None
        skipped["identification.crosstab"] = "no answered texture identification trials (period_us with answer_hz)"
    else:
        ident_section["crosstab"] = crosstab(ident)
    kendall = guarded(skipped, "kendall_tau", kendall_tau, ident)
    section.update(kendall or {"kendall_tau": None, "kendall_tau_p": None, "kendall_tau_variant": "tau-b",
                               "kendall_tau_n": int(len(ident))})
    return section, skipped


def posthoc(pairs: pd.DataFrame, reference: str | None) -> dict:
    """Paired t-tests of every pair of comparisons (pingouin.pairwise_tests, padjust="bonf": the
    p values are multiplied by the number of pairs, all k(k−1)/2 of them, as SPSS's Bonferroni
    post-hoc does), listed for the pairs that involve the reference comparison."""
    import pingouin as pg

    if reference is None:
        raise Skip("no reference comparison (one pair of identical textures) to test against")
    cells, _ = complete_cells(pairs, "rating", ["comparison"], "participant")
    if cells["participant"].nunique() < MIN_SUBJECTS:
        raise Skip(f"needs at least {MIN_SUBJECTS} participants with every comparison")
    with quiet():
        table = pg.pairwise_tests(data=cells, dv="rating", within="comparison", subject="participant",
                                  padjust="bonf")
    means = cells.groupby("comparison")["rating"].mean()
    rows = []
    for r in table.to_dict("records"):
        if reference not in (r["A"], r["B"]):
            continue
        other = r["B"] if r["A"] == reference else r["A"]
        rows.append({"comparison": other, "vs": reference, "A": r["A"], "B": r["B"], "T": num(r["T"]),
                     "dof": num(r["dof"]), "p_unc": num(r["p_unc"]), "p_bonf": num(r["p_corr"]),
                     "hedges_g": num(r["hedges"]), "mean_diff": num(means[other] - means[reference])})
    return {"method": "paired t-tests, Bonferroni over all pairs", "n_pairs_corrected": int(len(table)),
            "n_participants": int(cells["participant"].nunique()), "tests": rows}


def crosstab(ident: pd.DataFrame) -> dict:
    """Counts of actual (rows) × detected (columns) frequency, and the hit rate per actual."""
    table = pd.crosstab(ident["actual_hz"], ident["detected_hz"])
    rows, cols = [num(v) for v in table.index], [num(v) for v in table.columns]
    hits = {a: num(table.loc[a, a] / table.loc[a].sum()) if a in table.columns else 0.0 for a in table.index}
    return {"actual_hz": rows, "detected_hz": cols, "counts": table.to_numpy().astype(int).tolist(),
            "hit_rate": [{"actual_hz": num(a), "rate": hits[a], "n": int(table.loc[a].sum())} for a in table.index],
            "accuracy": num(sum(table.loc[a, a] for a in table.index if a in table.columns) / table.to_numpy().sum())}


def kendall_tau(ident: pd.DataFrame) -> dict:
    """Kendall's tau-b (scipy.stats.kendalltau, variant="b") of actual vs detected frequency over
    all identification trials, and its two-sided p (the trials are treated as independent, as
    in the thesis)."""
    from scipy.stats import kendalltau

    if ident["actual_hz"].nunique() < 2 or ident["detected_hz"].nunique() < 2:
        raise Skip("needs at least two different actual and two different detected frequencies "
                   f"(got {ident['actual_hz'].nunique()} and {ident['detected_hz'].nunique()})")
    with quiet():
        result = kendalltau(ident["actual_hz"].to_numpy(float), ident["detected_hz"].to_numpy(float), variant="b")
    return {"kendall_tau": num(result.statistic), "kendall_tau_p": num(result.pvalue), "kendall_tau_variant": "tau-b",
            "kendall_tau_n": int(len(ident))}
