"""Psychophysics tasks in `viestac analyze`: every answered main trial whose `metrics["psy"]` is a
psychophysics record (docs/psychophysics.md, "stats.json keys"), grouped per task × condition,
analysed per participant and pooled over the participants.

Pure over the loaded frame: the fits, bootstrap, d′ and information transfer are those of
server/psychophysics/ (fit.py, sdt.py, information.py); this module groups the trials, picks the
family, seeds the bootstrap and names the results the way stats.json does. Deterministic: the
bootstrap of a cell draws from a generator seeded by (BOOTSTRAP_SEED, the cell's name), so the
same database gives the same numbers, whatever else it holds.

- Psychometric fit (fit.py): the data are (level, trials, correct) per distinct level. nAFC and
  2IFC: every trial; yes/no and same–different: the signal trials (signal present / pair
  different), whose "correct" is the answer "yes" / "different"; identification has no fit. Guess
  rate fixed by the design (the record's `guess`), lapse fitted within [0, LAPSE_MAX]. All four
  families are fitted to the pooled data of a condition; the one with the highest likelihood
  (Weibull only for levels > 0; ties to the earlier of FAMILIES) is that condition's family, for
  the pooled fit and each participant's, so their thresholds are comparable.
- Parametric bootstrap (fit.bootstrap): BOOTSTRAP_SAMPLES resampled data sets at the same levels
  and trial counts; percentile 95 % intervals of threshold and slope; the deviance's bootstrap p.
- The procedure's own estimate: the record's `estimate` after the participant's last trial of the
  condition (pooled: the mean over the participants).
- d′ and criterion (sdt.py, log-linear rates): yes/no (hits = "yes" to signal trials, false alarms =
  "yes" to catch trials) and same–different (the differencing model).
- Information transfer (information.py): the identification confusion matrix (stimulus × answer),
  maximum-likelihood estimate and its Miller–Madow correction.
"""

from __future__ import annotations

import math
import re
import zlib
from typing import Any

import numpy as np
import pandas as pd

from server.analysis.stats import num
from server.psychophysics import information, sdt
from server.psychophysics.fit import bootstrap, fit
from server.psychophysics.functions import FAMILIES as FUNCTIONS

FAMILIES = ("logistic", "normal", "gumbel", "weibull")
LAPSE_MAX = 0.06            # Wichmann & Hill 2001a: a lapse bound of a few per cent keeps α and β unbiased
BOOTSTRAP_SAMPLES = 400     # bounded: a cell's bootstrap stays well under a second
BOOTSTRAP_SEED = 36
DESIGNS = ("yes-no", "nafc", "2ifc", "same-different", "identification")
SIGNAL_DESIGNS = ("yes-no", "same-different")   # fit on the signal trials; d′ from signal and noise trials
POOLED = "pooled"
METHOD = (f"psychophysics: maximum-likelihood psychometric fits (server/psychophysics/fit.py; guess rate fixed by "
          f"the design, lapse within [0, {LAPSE_MAX}]; the family of a condition — logistic, normal, Gumbel or "
          f"Weibull — is the one of highest likelihood on its pooled data), parametric bootstrap of "
          f"{BOOTSTRAP_SAMPLES} data sets (percentile 95 % intervals of threshold and slope, the deviance's "
          f"bootstrap p), d′ and criterion with log-linear rates (same–different: the differencing model), "
          f"information transfer with the Miller–Madow bias correction")
COLUMNS = ("task", "condition", "participant", "session", "seq", "design", "parameter", "unit", "level",
           "reference", "target", "signal", "stimulus_index", "choices", "answer", "answer_index", "correct", "guess",
           "trial", "reversal", "estimate")


def select(trials: pd.DataFrame) -> tuple[pd.DataFrame, dict[str, int]]:
    """The answered main trials with a psychophysics record, one row each (COLUMNS), in session
    order; and per task the number of such trials whose record cannot be used (a reason in the
    stats' `skipped`)."""
    rows, unusable = [], {}
    if not trials.empty:
        keep = (trials["kind"] == "main") & (trials["status"] == "answered")
        for t in trials[keep].itertuples(index=False):
            psy = t.metrics.get("psy") if isinstance(t.metrics, dict) else None
            if psy is None:
                continue
            row = _row(t, psy)
            if row is None:
                unusable[t.task] = unusable.get(t.task, 0) + 1
            else:
                rows.append(row)
    frame = pd.DataFrame(rows, columns=COLUMNS)
    if not frame.empty:
        frame = frame.sort_values(["task", "session", "seq"], kind="stable").reset_index(drop=True)
    return frame, unusable


def _row(t, psy) -> dict | None:
    """A usable record as a row; None when it lacks what every analysis needs."""
    if not isinstance(psy, dict) or psy.get("design") not in DESIGNS:
        return None
    level, choices = _finite(psy.get("level")), psy.get("choices")
    if level is None or not isinstance(choices, list) or not choices:
        return None
    correct = psy.get("correct")
    if psy["design"] != "identification" and not isinstance(correct, bool):
        return None
    condition = psy.get("condition")
    return {"task": t.task, "condition": "main" if condition is None else str(condition),
            "participant": t.participant, "session": t.session, "seq": int(t.seq), "design": psy["design"],
            "parameter": psy.get("parameter"), "unit": psy.get("unit"), "level": level,
            "reference": _finite(psy.get("reference")), "target": psy.get("target"), "signal": psy.get("signal"),
            "stimulus_index": psy.get("stimulus_index"), "choices": [str(c) for c in choices],
            "answer": psy.get("answer"), "answer_index": psy.get("answer_index"), "correct": correct,
            "guess": _finite(psy.get("guess")) or 0.0, "trial": psy.get("trial"),
            "reversal": bool(psy.get("reversal")), "estimate": psy.get("estimate")}


def _finite(value) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return float(value) if math.isfinite(value) else None


def analyze(rows: pd.DataFrame, unusable: dict[str, int] | None = None, samples: int = BOOTSTRAP_SAMPLES,
            lapse_max: float = LAPSE_MAX) -> tuple[dict, dict]:
    """The `psychophysics` section of stats.json and the skipped analyses (dotted path → reason)."""
    skipped: dict[str, str] = {}
    for task, n in sorted((unusable or {}).items()):
        skipped[f"psychophysics.{task}.unusable"] = (f"{n} answered trial(s) whose metrics.psy lacks a known design, "
                                                     f"a finite level, the choices or (but for identification) "
                                                     f"`correct`: left out")
    tasks = [_task(task, g, skipped, samples, lapse_max) for task, g in rows.groupby("task", sort=True)] \
        if not rows.empty else []
    section = {"n_trials": int(len(rows)), "n_participants": int(rows["participant"].nunique()) if len(rows) else 0,
               "n_tasks": len(tasks), "families": list(FAMILIES), "lapse_max": lapse_max,
               "bootstrap_samples": samples, "bootstrap_seed": BOOTSTRAP_SEED, "tasks": tasks}
    return section, skipped


def _task(task: str, g: pd.DataFrame, skipped: dict, samples: int, lapse_max: float) -> dict:
    first = g.iloc[0]
    design = first["design"]
    out = {"task": task, "design": design, "parameter": first["parameter"], "unit": first["unit"],
           "guess": float(first["guess"]), "choices": list(first["choices"]), "n_trials": int(len(g)),
           "n_participants": int(g["participant"].nunique()), "conditions": []}
    for condition, c in g.groupby("condition", sort=True):
        out["conditions"].append(_condition(task, str(condition), design, c, skipped, samples, lapse_max))
    return out


def _condition(task, condition, design, c: pd.DataFrame, skipped, samples, lapse_max) -> dict:
    where = f"psychophysics.{task}.{condition}"
    families = _families(fit_data(c, design), float(c["guess"].iloc[0]), lapse_max) if design != "identification" \
        else {}
    family = max(families, key=lambda f: families[f]["log_likelihood"] + 1e-9 * (len(FAMILIES) - FAMILIES.index(f)),
                 default=None)
    participants = [_cell(f"{where}.{who}", design, p, family, samples, lapse_max, skipped, who)
                    for who, p in c.groupby("participant", sort=True)]
    pooled = _cell(f"{where}.{POOLED}", design, c, family, samples, lapse_max, skipped, None)
    estimates = [p["procedure_estimate"] for p in participants if p["procedure_estimate"] is not None]
    pooled["procedure_estimate"] = num(np.mean(estimates)) if estimates else None
    pooled["procedure_estimate_n"] = len(estimates)
    return {"condition": condition, "n_trials": int(len(c)), "n_participants": int(c["participant"].nunique()),
            "family": family, "families": families, "pooled": pooled, "participants": participants}


def fit_data(c: pd.DataFrame, design: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(levels, trials, correct) per distinct level of the trials the fit uses."""
    used = c[c["signal"] == True] if design in SIGNAL_DESIGNS else c  # noqa: E712 - a column of True/False/None
    if used.empty:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    table = used.groupby("level", sort=True)["correct"].agg(["size", "sum"])
    return table.index.to_numpy(dtype=float), table["size"].to_numpy(dtype=float), table["sum"].to_numpy(dtype=float)


def _families(data, guess: float, lapse_max: float) -> dict:
    """Every family's fit to these data (Weibull only for levels > 0; a family that cannot be fitted
    is left out): threshold, slope, lapse, deviance, log_likelihood."""
    levels, n, k = data
    out = {}
    for family in FAMILIES:
        if family == "weibull" and (len(levels) == 0 or levels.min() <= 0):
            continue
        try:
            f = fit(levels, n, k, family, guess, _lapse(guess, lapse_max))
        except ValueError:
            continue
        out[family] = {"threshold": num(f.threshold), "slope": num(f.slope), "lapse": num(f.lapse),
                       "deviance": num(f.deviance), "log_likelihood": num(f.log_likelihood)}
    return out


def _lapse(guess: float, lapse_max: float) -> float:
    return min(lapse_max, max(0.0, 0.999 - guess))


def _cell(path, design, c: pd.DataFrame, family, samples, lapse_max, skipped, participant) -> dict:
    levels, n, k = fit_data(c, design) if design != "identification" else (np.zeros(0),) * 3
    cell: dict[str, Any] = {"participant": participant, "n_trials": int(len(c)),
                            "points": [{"level": num(x), "n": int(a), "k": int(b), "p": num(b / a)}
                                       for x, a, b in zip(levels, n, k)],
                            "fit": None, "bootstrap": None, "procedure_estimate": _procedure_estimate(c),
                            "sdt": None, "information": None}
    if design != "identification":
        cell["fit"], cell["bootstrap"] = _fit(path, levels, n, k, float(c["guess"].iloc[0]), family, samples,
                                              lapse_max, skipped)
    if design in SIGNAL_DESIGNS:
        cell["sdt"] = _sdt(path, design, c, skipped)
    if design == "identification":
        cell["information"] = _information(path, c, skipped)
    return cell


def _fit(path, levels, n, k, guess, family, samples, lapse_max, skipped):
    if len(levels) < 2:
        skipped[f"{path}.fit"] = f"a psychometric fit needs trials at 2 or more distinct levels, got {len(levels)}"
        return None, None
    if family is None:
        skipped[f"{path}.fit"] = (f"no family could be fitted to the condition's pooled data (guess rate {guess:g}: "
                                  f"it must lie in [0, 1))")
        return None, None
    if family == "weibull" and levels.min() <= 0:
        skipped[f"{path}.fit"] = "the condition's family is Weibull, which needs levels > 0"
        return None, None
    lapse = _lapse(guess, lapse_max)
    try:
        f = fit(levels, n, k, family, guess, lapse)
    except ValueError as exc:
        skipped[f"{path}.fit"] = str(exc)
        return None, None
    result = {"family": family, "guess": guess, "threshold": num(f.threshold), "slope": num(f.slope),
              "lapse": num(f.lapse), "midpoint": num(midpoint(family, f.threshold, f.slope)),
              "deviance": num(f.deviance), "log_likelihood": num(f.log_likelihood), "converged": f.converged,
              "n_levels": int(len(levels)), "n_trials": int(n.sum())}
    if samples <= 0:  # e.g. a power analysis that needs the estimates only (its CPU goes to the replications)
        skipped[f"{path}.bootstrap"] = "no bootstrap asked (0 samples)"
        return result, None
    rng = np.random.default_rng([BOOTSTRAP_SEED, zlib.crc32(path.encode("utf-8"))])
    b = bootstrap(f, levels, n, rng, samples=samples, lapse_max=lapse)
    mid = np.percentile(midpoint(family, b.thresholds, b.slopes), [2.5, 97.5])
    boot = {"samples": samples, "threshold_ci95": [num(b.threshold_ci[0]), num(b.threshold_ci[1])],
            "slope_ci95": [num(b.slope_ci[0]), num(b.slope_ci[1])], "midpoint_ci95": [num(mid[0]), num(mid[1])],
            "deviance_p": num(b.deviance_p)}
    return result, boot


def midpoint(family: str, threshold, slope):
    """The level where the curve is halfway from the guess rate to 1 − λ (F = ½): the same point of
    every family (α itself for logistic and normal; below α for Gumbel and Weibull, whose F(α) is
    1 − 1/e), so thresholds of different families compare."""
    return FUNCTIONS[family].level_at(0.5, threshold, slope)


def _procedure_estimate(c: pd.DataFrame) -> float | None:
    """The procedure's estimate after the last trial (a number; a condition's entry of an
    interleaved estimate; a QUEST+ posterior's threshold)."""
    if c.empty:
        return None
    last = c.iloc[-1]
    return _estimate_value(last["estimate"], last["condition"])


def _estimate_value(estimate, condition: str | None) -> float | None:
    if isinstance(estimate, dict):
        if condition is not None and condition in estimate:
            return _estimate_value(estimate[condition], None)
        if "threshold" in estimate:
            return _estimate_value(estimate["threshold"], None)
        return None
    return _finite(estimate)


def _sdt(path, design, c: pd.DataFrame, skipped) -> dict | None:
    signal = c[c["signal"] == True]    # noqa: E712
    noise = c[c["signal"] == False]    # noqa: E712
    if signal.empty or noise.empty:
        what = "catch (signal-absent)" if design == "yes-no" else "same"
        skipped[f"{path}.sdt"] = (f"d′ needs signal trials and {what} trials, got {len(signal)} and {len(noise)}")
        return None
    hits = int(signal["correct"].sum())
    false_alarms = int((~noise["correct"].astype(bool)).sum())
    fn = sdt.yes_no if design == "yes-no" else sdt.same_different
    s = fn(hits, len(signal), false_alarms, len(noise))
    return {"model": "yes-no" if design == "yes-no" else "differencing", "correction": "loglinear",
            "hits": hits, "signal_trials": int(len(signal)), "false_alarms": false_alarms,
            "noise_trials": int(len(noise)), "hit_rate": num(s.hit_rate), "false_alarm_rate": num(s.false_alarm_rate),
            "d_prime": num(s.d_prime), "criterion": num(s.criterion)}


def confusion(c: pd.DataFrame) -> tuple[list[str], np.ndarray]:
    """The identification confusion matrix: rows the stimulus (index into the choices), columns
    the answer; trials without a valid stimulus or answer index are left out."""
    labels = list(c["choices"].iloc[0])
    k = len(labels)
    counts = np.zeros((k, k), dtype=int)
    for s, a in zip(c["stimulus_index"], c["answer_index"]):
        i, j = _index(s, k), _index(a, k)
        if i is not None and j is not None:
            counts[i, j] += 1
    return labels, counts


def _index(value, k: int) -> int | None:
    """A whole number in 0..k−1 (a frame column mixing indices and nulls holds them as floats)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        return None
    return int(value) if math.isfinite(value) and float(value).is_integer() and 0 <= value < k else None


def _information(path, c: pd.DataFrame, skipped) -> dict | None:
    labels, counts = confusion(c)
    if counts.sum() == 0:
        skipped[f"{path}.information"] = "no identification trial has a stimulus and an answer index"
        return None
    it = information.information_transfer(counts)
    return {"labels": labels, "confusion": counts.tolist(), "trials": it.trials,
            "accuracy": num(np.trace(counts) / counts.sum()), "bits": num(it.bits), "corrected": num(it.corrected),
            "correction": num(it.correction), "maximum": num(it.maximum), "correction_method": "Miller-Madow"}


def slug(name: str) -> str:
    """A task or condition name as part of a file name."""
    return re.sub(r"[^A-Za-z0-9_-]+", "-", str(name)).strip("-") or "x"
