"""The report card's numbers, pure over analysed battery data (docs/report-card.md).

Input per device: its model, the `viestac analyze` results of its battery study (run.compute: the
psychophysics section and task 4 with its kept positioning trials) and optionally an audio
calibration. Output: stats.json's content. Every number the page prints is read from here.

- Each part of `plan_for(model)` is "measured" (its task has analysed data), "skipped" (the device
  cannot show it: the capability check's words) or "no data" (runnable, nothing recorded yet).
- A psychophysics measure is the pooled fit's threshold α of its condition
  (server/analysis/psychophysics.py) turned into the part's measure: a detection threshold is α,
  a change threshold or JND α − reference, a Weber fraction (α − reference) / reference (both
  with the sign turned where the comparisons lie below the reference, as stiffness's do), an
  amplitude JND in dB 20·log10(α / reference); its 95 % CI is the bootstrap's threshold interval
  turned the same way. Information transfer is the mean of the participants' Miller–Madow corrected
  estimates with its t interval (the pooled matrix's estimate beside it). Positioning: task 4's per-device
  description (mean and t interval over the participants' means).
- A fitted α outside the range of levels tested (e.g. a detection staircase pinned at 100 % at a
  carrier the device barely renders) is kept but flagged (`within_tested_range` false): the page
  marks it and the figures leave it out.
- Paired comparisons: per measure, for two devices worn by the same participants (the
  participant code), the per-participant values compared with the Wilcoxon signed-rank test (the
  verdict: thresholds and Weber fractions from short staircases are skewed, and the groups are
  small) and the paired t-test beside it.
"""

from __future__ import annotations

import math
import re
from itertools import combinations
from typing import Any

import numpy as np
import pandas as pd

from devices.profiles import profile_by_model
from server.analysis.stats import num, t_interval
from server.analysis.task4 import GUIDANCE_CUES
from server.battery.parts import BY_ID, PARTS, PartPlan
from server.psychophysics import literature

FORMAT, FORMAT_VERSION = "viestac-report-card", 2  # 2: the detection band as low and high edges
MIN_PAIRS = 5          # fewer common participants: no paired test (said in `skipped`)
# measure key → (label, how it is made from α and the part's reference)
MEASURES = {
    "threshold": "detection threshold",
    "change_threshold": "change-detection threshold",
    "jnd": "JND",
    "amplitude_jnd_db": "amplitude JND (dB)",
    "frequency_weber": "frequency Weber fraction",
    "texture_weber": "texture period Weber fraction",
    "stiffness_weber": "stiffness Weber fraction",
    "it_bits": "information transfer (bits)",
    "trajectory_length": "path length (scene units)",
    "completion_time": "completion time (s)",
}
WEBER = {"frequency_jnd": "frequency_weber", "texture_period": "texture_weber", "stiffness": "stiffness_weber"}
METHODS = {
    "threshold": "pooled maximum-likelihood psychometric fit per condition (viestac analyze, "
                 "server/analysis/psychophysics.py): its threshold α; 95 % CI: the parametric bootstrap's "
                 "percentile interval",
    "derived": "JND = α − reference; Weber fraction = (α − reference) / reference, both negated where the "
               "comparisons lie below the reference (stiffness); amplitude JND (dB) = "
               "20·log10(α / reference); their CIs are the bootstrap interval of α turned the same way",
    "it_bits": "information transfer with the Miller–Madow correction, per participant (their own confusion "
               "matrix), averaged; 95 % CI: t interval over the participants; the pooled matrix's estimate is "
               "listed beside it (`pooled`)",
    "positioning": "viestac analyze task 4 over the device's guidance trials: mean, t interval over the "
                   "participants' means",
    "paired": f"participants who wore both devices (same participant code), per-participant values: Wilcoxon "
              f"signed-rank test (scipy.stats.wilcoxon, two-sided) as the verdict — per-participant thresholds "
              f"and Weber fractions are skewed and the groups small, so no normality is assumed; the paired "
              f"t-test (scipy.stats.ttest_rel) beside it; at least {MIN_PAIRS} pairs",
    "physical": "audio tactor with a calibration (devices/audio/config.py): the threshold's drive "
                "(intensity/100 · gain, capped at the channel's peak) at the condition's carrier turned into "
                "the calibrated peak",
}


def device_card(model: str, plans: tuple[PartPlan, ...], analysis: dict, kept: pd.DataFrame,
                calibration=None) -> dict:
    """One device's card: every part of its plan, measured, skipped or without data."""
    psy_tasks = {t["task"]: t for t in analysis["psychophysics"]["tasks"]}
    parts = []
    for plan in plans:
        part = plan.part
        row: dict[str, Any] = {"part": part.id, "title": part.title, "status": None, "reason": None,
                               "planned_trials": plan.trials, "minutes": plan.minutes, "measures": []}
        if not plan.runs:
            row.update(status="skipped", reason=plan.reason)
        elif part.id == "positioning":
            row["measures"] = _positioning(model, analysis["task4"], kept)
        elif part.id in psy_tasks:
            row["measures"] = _psy_measures(part.id, psy_tasks[part.id], calibration,
                                            profile_by_model(model).carrier_hz, direction(plan))
        if row["status"] is None:
            row["status"] = "measured" if row["measures"] else "no data"
            if not row["measures"]:
                row["reason"] = "no analysed trials of this part in the data"
        parts.append(row)
    known = {p.id for p in PARTS}
    extra = sorted(set(psy_tasks) - known)
    return {"model": model, "parts": parts, "extra_tasks": extra,
            "n_participants": int(analysis["provenance"]["n_participants"]),
            "participants": sorted({s["participant"] for s in analysis["provenance"]["sessions"]}),
            "calibration": None if calibration is None else {"unit": calibration[1].unit}}


def carrier_of(condition: str) -> float | None:
    m = re.fullmatch(r"f(\d+(?:\.\d+)?)", condition)
    return float(m.group(1)) if m else None


def direction(plan: PartPlan) -> int:
    """+1 when the part's comparisons lie above its reference (the staircase's range starts at or
    above it), −1 below (stiffness: softer than the reference), so a JND is positive either way."""
    procedure = (plan.task or {}).get("psychophysics", {}).get("procedure", {})
    low, ref = procedure.get("min"), plan.part.reference
    return -1 if low is not None and ref is not None and low < ref else 1


def _transform(part_id: str, sign: int):
    """(measure key, unit override or None, α → value) of a psychophysics part."""
    ref = BY_ID[part_id].reference
    if part_id == "detection":
        return [("threshold", None, lambda a: a)]
    if part_id == "temperature_change":
        return [("change_threshold", None, lambda a: a - ref)]
    if part_id == "amplitude_jnd":
        return [("jnd", None, lambda a: a - ref),
                ("amplitude_jnd_db", "dB", lambda a: 20 * math.log10(a / ref) if a > 0 else math.nan)]
    if part_id == "tilt_direction":
        return [("jnd", None, lambda a: a - ref)]
    if part_id in WEBER:
        return [("jnd", None, lambda a: sign * (a - ref)), (WEBER[part_id], "", lambda a: sign * (a - ref) / ref)]
    return []


def _interval(f, pair) -> list | None:
    if not pair or pair[0] is None or pair[1] is None:
        return None
    a, b = f(pair[0]), f(pair[1])
    if not (math.isfinite(a) and math.isfinite(b)):
        return None
    lo, hi = sorted((a, b))  # a measure that falls with α (comparisons below the reference) swaps the ends
    return [num(lo), num(hi)]


def _psy_measures(part_id: str, task: dict, calibration, own_carrier_hz: float | None, sign: int) -> list[dict]:
    out = []
    if part_id == "angle_identification":
        for cond in task["conditions"]:
            pooled = cond["pooled"]["information"]
            if pooled is None:
                continue
            per = {c["participant"]: c["information"]["corrected"] for c in cond["participants"]
                   if c["information"] is not None and c["information"]["corrected"] is not None}
            lo, hi = t_interval(np.array(list(per.values()), dtype=float))
            out.append({"measure": "it_bits", "label": MEASURES["it_bits"], "condition": cond["condition"],
                        "value": num(np.mean(list(per.values()))) if per else None,
                        "ci95": None if lo is None else [lo, hi], "unit": "bits",
                        "pooled": pooled["corrected"], "maximum": pooled["maximum"], "n_participants": cond["n_participants"],
                        "n_trials": cond["n_trials"], "per_participant": per, "physical": None})
        return out
    for cond in task["conditions"]:
        fit = cond["pooled"]["fit"]
        if fit is None:
            continue
        boot = cond["pooled"]["bootstrap"]
        levels = [pt["level"] for pt in cond["pooled"]["points"]]
        tested = [min(levels), max(levels)] if levels else None
        # a threshold beyond every level tested (a staircase pinned at the device's maximum) is an
        # extrapolation of the fit, not a measurement: kept, flagged, left out of the figures
        within = tested is not None and tested[0] <= fit["threshold"] <= tested[1]
        for key, unit, f in _transform(part_id, sign):
            value = f(fit["threshold"])
            if not math.isfinite(value):
                continue
            per = {c["participant"]: num(f(c["fit"]["threshold"])) for c in cond["participants"]
                   if c["fit"] is not None and math.isfinite(f(c["fit"]["threshold"]))}
            ci = _interval(f, boot["threshold_ci95"]) if boot else None
            row = {"measure": key, "label": MEASURES[key], "condition": cond["condition"], "value": num(value),
                   "ci95": ci, "unit": task["unit"] if unit is None else unit,
                   "n_participants": cond["n_participants"], "n_trials": cond["n_trials"],
                   "alpha": fit["threshold"], "tested_range": tested, "within_tested_range": within,
                   "per_participant": per, "physical": None}
            if key == "threshold":
                row["carrier_hz"] = carrier_of(cond["condition"]) or own_carrier_hz
                row["physical"] = physical(calibration, row["carrier_hz"], value, ci)
            out.append(row)
    return out


def physical(calibration, carrier_hz: float | None, pct: float, ci: list | None) -> dict | None:
    """A threshold in % of the drive as the calibrated peak at its carrier (None: no calibration,
    or a carrier outside it)."""
    if calibration is None or carrier_hz is None:
        return None
    channel, cal = calibration
    if not cal.covers(carrier_hz, carrier_hz):
        return {"value": None, "unit": cal.unit, "reason": f"{carrier_hz:g} Hz is outside the calibration"}

    def peak(x: float) -> float:
        return num(cal.peak_for(carrier_hz, channel.drive(x)))

    return {"value": peak(pct), "ci95": None if ci is None else [peak(ci[0]), peak(ci[1])], "unit": cal.unit,
            "reason": None}


def _positioning(model: str, task4: dict, kept: pd.DataFrame) -> list[dict]:
    section = task4.get(model)
    if not isinstance(section, dict) or "trajectory_length" not in section:
        return []
    rows = kept[(kept["device"] == model) & kept["cue"].isin(GUIDANCE_CUES)] if not kept.empty else kept
    out = []
    for key in ("trajectory_length", "completion_time"):
        d = section[key]
        if d["mean"] is None:
            continue
        per = {str(k): num(v) for k, v in rows.groupby("participant")[key].mean().dropna().items()} \
            if not rows.empty else {}
        out.append({"measure": key, "label": MEASURES[key], "condition": "main", "value": d["mean"],
                    "ci95": None if d["ci95_low"] is None else [d["ci95_low"], d["ci95_high"]],
                    "unit": "s" if key == "completion_time" else "scene units",
                    "n_participants": d["n_participants"], "n_trials": d["n_trials"], "per_participant": per,
                    "physical": None})
    return out


def comparison(cards: list[dict], skipped: dict) -> dict:
    """The side-by-side table (every measure × condition, per device) and the paired tests."""
    table: dict[tuple, dict] = {}
    for card in cards:
        for part in card["parts"]:
            for m in part["measures"]:
                row = table.setdefault((part["part"], m["measure"], m["condition"]),
                                       {"part": part["part"], "measure": m["measure"], "label": m["label"],
                                        "condition": m["condition"], "unit": m["unit"], "devices": {}})
                row["devices"][card["model"]] = {k: m[k] for k in ("value", "ci95", "n_participants")}
    rows = [table[k] for k in sorted(table)]
    tests = []
    by_model = {c["model"]: c for c in cards}
    for (part, measure, condition), row in sorted(table.items()):
        for a, b in combinations(sorted(row["devices"]), 2):
            va, vb = _values(by_model[a], part, measure, condition), _values(by_model[b], part, measure, condition)
            common = sorted(set(va) & set(vb))
            where = f"paired.{part}.{measure}.{condition}.{a}-{b}"
            if len(common) < MIN_PAIRS:
                skipped[where] = f"{len(common)} participant(s) wore both devices; a paired test needs {MIN_PAIRS}"
                continue
            tests.append(paired(part, measure, condition, a, b, [va[p] for p in common], [vb[p] for p in common]))
    return {"table": rows, "paired": tests}


def _values(card: dict, part: str, measure: str, condition: str) -> dict:
    for p in card["parts"]:
        if p["part"] == part:
            for m in p["measures"]:
                if m["measure"] == measure and m["condition"] == condition:
                    return {k: v for k, v in m["per_participant"].items() if v is not None}
    return {}


def paired(part, measure, condition, a, b, xa: list[float], xb: list[float]) -> dict:
    from scipy import stats

    xa_, xb_ = np.asarray(xa, dtype=float), np.asarray(xb, dtype=float)
    diff = xa_ - xb_
    out = {"part": part, "measure": measure, "condition": condition, "devices": [a, b], "n_pairs": len(xa),
           "mean_difference": num(diff.mean()), "median_difference": num(np.median(diff)),
           "test": "wilcoxon", "wilcoxon": None, "t_test": None}
    if np.any(diff != 0):
        w = stats.wilcoxon(xa_, xb_)
        out["wilcoxon"] = {"statistic": num(w.statistic), "p": num(w.pvalue)}
        t = stats.ttest_rel(xa_, xb_)
        out["t_test"] = {"t": num(t.statistic), "df": len(xa) - 1, "p": num(t.pvalue)}
    return out


def card_stats(cards: list[dict], provenance: dict) -> dict:
    skipped: dict[str, str] = {}
    side = comparison(cards, skipped)
    return {"format": FORMAT, "format_version": FORMAT_VERSION, "provenance": provenance, "methods": METHODS,
            "literature": {"detection": literature.detection_band(), "bands": literature.bands(),
                           "sources": {k: s.citation for k, s in literature.SOURCES.items()}},
            "devices": cards, "comparison": side, "skipped": dict(sorted(skipped.items()))}
