"""Task 4, object positioning (thesis §5.5.3 and §5.6; docs/analysis.md).

Main positioning trials, each with its device (the task's, else the session's), its cue (params.cue,
else the scenario's cue: P1..P4, the two vibration modes, "3dof" = the FerroVibe's guidance, "none")
and its object (the target). Measures from the scenario's metrics: trajectory length (path_length),
completion time (completion_s), time to first reach the target, end-point error (hold_error_mean,
3-D, and hold_depth_error_mean); the helpfulness rating (response `helpfulness`).

- Outliers: per condition (device, cue, object), a trial whose trajectory length or completion
  time lies, in logarithms, outside Tukey's "far out" fences Q1 − 3·IQR .. Q3 + 3·IQR (pandas
  quantiles) is excluded from every task-4 statistic; listed in stats.json and the report.
  Logarithms because both measures are positive and right-skewed; 3·IQR rather than 1.5·IQR or
  median ± 3·MAD because with the thesis's 13 trials per condition those flag 3.7 % and 2.4 % of
  perfectly log-normal values, the far-out fences 0.4 % (simulated; docs/analysis.md), and the
  thesis excluded only values "far above the mean".
- Per device, over its guidance trials (patterns P1..P4 and 3dof; the thesis averaged the
  FingerTac's patterns): mean/SD/CI of each measure, per cue, per object and per cue × object; a
  repeated-measures ANOVA (pingouin, GG) over cue and/or object, whichever varies.
- Device comparison: per-participant means of each device, paired t-test (pingouin.ttest,
  paired=True) and Wilcoxon signed-rank test (scipy.stats.wilcoxon) over participants with both.
- Questionnaire answers: choice answers counted, numeric ones described.
- Speed-accuracy: Spearman correlations (scipy.stats.spearmanr) of completion time with trajectory
  length and with end-point error, per device (the chart is figures.speed_accuracy).
"""

from __future__ import annotations

from itertools import combinations

import numpy as np
import pandas as pd

from server.analysis.load import answered, number
from server.analysis.stats import MIN_SUBJECTS, Skip, describe, guarded, num, quiet, rm_anova

SCENARIO = "positioning"
PATTERNS = ("P1", "P2", "P3", "P4")
GUIDANCE_CUES = PATTERNS + ("3dof",)
THESIS_DEVICES = ("fingertac", "ferrovibe")
METRICS = {"trajectory_length": "path_length", "completion_time": "completion_s",
           "time_to_target": "time_to_target_s", "end_error": "hold_error_mean",
           "end_depth_error": "hold_depth_error_mean"}
MEASURES = ("trajectory_length", "completion_time", "helpfulness", "end_error")
OUTLIER_MEASURES = ("trajectory_length", "completion_time")
OUTLIER_K = 3.0
OUTLIER_MIN_N = 4
OUTLIER_RULE = ("per condition (device, cue, object): a trajectory length or completion time whose logarithm lies "
                "below Q1 − 3·IQR or above Q3 + 3·IQR of the condition's logarithms (Tukey's 'far out' fences); "
                "conditions with fewer than 4 trials or no spread (IQR = 0) are not screened")
COLUMNS = ("trial_id", "participant", "task", "device", "cue", "object", "hole_speed", "tick_hz", *METRICS,
           "helpfulness")


def select(trials: pd.DataFrame) -> pd.DataFrame:
    """Answered main positioning trials with their measures (NaN where not recorded)."""
    rows = []
    for t in answered(trials, SCENARIO).itertuples():
        cue = t.params.get("cue") or t.scenario_params.get("cue")
        measures = [number(t.metrics.get(m)) for m in METRICS.values()]
        rows.append((t.trial_id, t.participant, t.task, t.device, cue, t.params.get("object"),
                     number(t.scenario_params.get("hole_speed")) or 0.0, t.tick_hz, *measures,
                     number(t.responses.get("helpfulness"))))
    return pd.DataFrame(rows, columns=COLUMNS).astype({m: float for m in (*METRICS, "helpfulness")})


def select_questionnaire(trials: pd.DataFrame) -> pd.DataFrame:
    rows = [(t.participant, t.task, t.device, q, v)
            for t in answered(trials, SCENARIO, ("questionnaire",)).itertuples() for q, v in t.responses.items()]
    return pd.DataFrame(rows, columns=("participant", "task", "device", "question", "value"))


def flag_outliers(frame: pd.DataFrame) -> pd.DataFrame:
    """The rows that break the outlier rule, with the measure, value and the condition's fences."""
    out = []
    for (device, cue, obj), group in frame.groupby(["device", "cue", "object"], sort=True, dropna=False):
        for measure in OUTLIER_MEASURES:
            x = np.log(group[measure][group[measure] > 0])  # positive and right-skewed: screened in logs
            if len(x) < OUTLIER_MIN_N:
                continue
            q1, q3 = (float(v) for v in x.quantile([0.25, 0.75]))
            if q3 == q1:        # half the values equal: no spread to judge by
                continue
            low, high = q1 - OUTLIER_K * (q3 - q1), q3 + OUTLIER_K * (q3 - q1)
            for row in group.loc[x[(x < low) | (x > high)].index].itertuples():
                out.append({"trial_id": int(row.trial_id), "participant": row.participant, "device": device,
                            "cue": cue, "object": obj, "measure": measure, "value": num(getattr(row, measure)),
                            "median": num(group[measure].median()), "low": num(np.exp(low)),
                            "high": num(np.exp(high))})
    return pd.DataFrame(out, columns=("trial_id", "participant", "device", "cue", "object", "measure", "value",
                                      "median", "low", "high"))


def analyze(frame: pd.DataFrame, questionnaire: pd.DataFrame) -> tuple[dict, dict, pd.DataFrame]:
    """stats.json's `task4` section (without the throughput), its skipped analyses, and the
    trials kept after the outlier rule (for the throughput and the charts)."""
    skipped: dict[str, str] = {}
    flags = flag_outliers(frame)
    kept = frame[~frame["trial_id"].isin(flags["trial_id"])]
    section: dict = {"n_trials": int(len(frame)), "n_participants": int(frame["participant"].nunique()),
                     "guidance_cues": list(GUIDANCE_CUES),
                     "outliers": {"rule": OUTLIER_RULE, "k": OUTLIER_K, "n_excluded": int(flags["trial_id"].nunique()),
                                  "trials": flags.to_dict("records")}}
    section["conditions"] = _by(kept, ["device", "cue", "object"])
    devices = list(dict.fromkeys([*THESIS_DEVICES, *kept["device"].dropna()]))
    for device in devices:
        rows = kept[(kept["device"] == device) & kept["cue"].isin(GUIDANCE_CUES)]
        if rows.empty:
            section[device] = None
            skipped[device] = f"no {device} positioning trials with a guidance cue ({', '.join(GUIDANCE_CUES)})"
            continue
        section[device] = _device(rows, device, skipped)
    section["comparison"] = {}
    present = [d for d in devices if section.get(d)]
    for a, b in combinations(present, 2):
        key = f"{a}_vs_{b}"
        section["comparison"][key] = guarded(skipped, f"comparison.{key}", compare_devices, kept, a, b)
    if len(present) < 2:
        skipped["comparison"] = f"needs two devices with guidance trials, got {present or 'none'}"
    section["questionnaire"] = questionnaire_summary(questionnaire)
    if not section["questionnaire"]:
        skipped["questionnaire"] = "no answered positioning questionnaires"
    section["speed_accuracy"] = {d: guarded(skipped, f"speed_accuracy.{d}", speed_accuracy, kept[kept["device"] == d])
                                 for d in present}
    return section, skipped, kept


def _by(rows: pd.DataFrame, by: list[str]) -> list[dict]:
    """Per group: its keys, then the description of every measure."""
    out = []
    for key, g in rows.groupby(by, sort=True):
        key = key if isinstance(key, tuple) else (key,)
        out.append({**dict(zip(by, key)), **{m: describe(g, m) for m in MEASURES}})
    return out


def _device(rows: pd.DataFrame, device: str, skipped: dict) -> dict:
    out = {"n_trials": int(len(rows)), "n_participants": int(rows["participant"].nunique()),
           "cues": sorted(rows["cue"].unique().tolist()), "objects": sorted(rows["object"].unique().tolist())}
    out.update({m: describe(rows, m) for m in MEASURES})
    for name, by in (("by_cue", ["cue"]), ("by_object", ["object"]), ("by_cue_object", ["cue", "object"])):
        out[name] = _by(rows, by)
    within = [w for w in ("cue", "object") if rows[w].nunique() > 1]
    out["rm_anova"] = {}
    for m in ("trajectory_length", "completion_time", "helpfulness"):
        path = f"{device}.rm_anova.{m}"
        if not within:
            out["rm_anova"][m] = None
            skipped[path] = "one cue and one object: nothing varies within participants"
        elif rows[m].notna().sum() == 0:
            out["rm_anova"][m] = None
            skipped[path] = f"no {m} recorded"
        else:
            out["rm_anova"][m] = guarded(skipped, path, rm_anova, rows, m, within)
    return out


def compare_devices(kept: pd.DataFrame, a: str, b: str) -> dict:
    """Per-participant means over each device's guidance trials, paired over the participants
    who used both: pingouin.ttest(paired=True) and scipy.stats.wilcoxon."""
    import pingouin as pg
    from scipy.stats import wilcoxon

    rows = kept[kept["cue"].isin(GUIDANCE_CUES)]
    out = {"devices": [a, b], "note": "device order was not counterbalanced in the thesis's design (§5.7)"}
    for m in ("trajectory_length", "completion_time", "helpfulness"):
        means = rows[rows["device"].isin((a, b))].groupby(["participant", "device"])[m].mean().unstack()
        pairs = means.dropna(subset=[d for d in (a, b) if d in means.columns]) if {a, b} <= set(means.columns) \
            else means.iloc[:0]
        n = int(len(pairs))
        if n < MIN_SUBJECTS:
            out[m] = None
            continue
        x, y = pairs[a].to_numpy(float), pairs[b].to_numpy(float)
        with quiet():
            t = pg.ttest(x, y, paired=True).to_dict("records")[0]
            try:
                w = wilcoxon(x, y)
                w_stat, w_p = num(w.statistic), num(w.pvalue)
            except ValueError:       # every difference zero
                w_stat = w_p = None
        ci = t.get("CI95")
        out[m] = {"n_pairs": n, f"mean_{a}": num(x.mean()), f"mean_{b}": num(y.mean()),
                  "mean_diff": num((x - y).mean()), "T": num(t["T"]), "dof": num(t["dof"]), "p": num(t["p_val"]),
                  "cohen_d": num(t["cohen_d"]), "diff_ci95": [num(v) for v in ci] if ci is not None else None,
                  "wilcoxon_W": w_stat, "wilcoxon_p": w_p}
    if all(out[m] is None for m in ("trajectory_length", "completion_time", "helpfulness")):
        raise Skip(f"needs at least {MIN_SUBJECTS} participants who used both {a} and {b}")
    return out


def questionnaire_summary(q: pd.DataFrame) -> dict:
    """Per question: counts of each choice (text answers), or the description of numeric ones."""
    out = {}
    for question, g in q.groupby("question", sort=True):
        values = g["value"].tolist()
        if all(isinstance(v, str) for v in values):
            counts = g["value"].value_counts()
            out[question] = {"kind": "choice", "tasks": sorted(g["task"].unique().tolist()), "n": len(values),
                             "counts": [{"value": v, "n": int(c), "share": num(c / len(values))}
                                        for v, c in sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))]}
        else:
            nums = g.assign(x=[number(v) for v in values]).dropna(subset=["x"])
            out[question] = {"kind": "rating", "tasks": sorted(g["task"].unique().tolist()), **describe(nums, "x")}
    return out


def speed_accuracy(rows: pd.DataFrame) -> dict:
    """Spearman's rho of completion time with trajectory length and with end-point error."""
    from scipy.stats import spearmanr

    out = {"n_trials": int(len(rows))}
    for name, other in (("time_vs_length", "trajectory_length"), ("time_vs_end_error", "end_error")):
        pair = rows[["completion_time", other]].dropna()
        if len(pair) < 3 or pair.nunique().min() < 2:
            out[name] = None
            continue
        with quiet():
            r = spearmanr(pair["completion_time"], pair[other])
        out[name] = {"rho": num(r.statistic), "p": num(r.pvalue), "n": int(len(pair))}
    if out["time_vs_length"] is None and out["time_vs_end_error"] is None:
        raise Skip("needs at least 3 completed trials with varying times and lengths or errors")
    return out
