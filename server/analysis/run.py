"""`viestac analyze`: load a study's sessions, run every analysis, write stats.json, the figures
(PNG + SVG) and report.html into one directory.

Outputs depend on the data only (no clock, fixed figure sizes and SVG salt), so analysing the same
database twice gives the same files.
"""

from __future__ import annotations

import importlib
import json
import multiprocessing
import os
import platform
import threading
from importlib import metadata
from pathlib import Path

import pandas as pd

from server import __version__
from server.analysis import fitts, figures, task1, task2, task3, task4
from server.analysis import psychophysics as psy
from server.analysis.load import Dataset, load
from server.analysis.stats import guarded
from server.analysis.task3 import FIT_LEVELS, FIT_METHOD
from server.analysis.task4 import OUTLIER_RULE

FORMAT, FORMAT_VERSION = "viestac-analysis", 1
LIBRARIES = ("numpy", "scipy", "pingouin", "statsmodels", "pandas", "matplotlib")
METHODS = {
    "ci": "95 % confidence intervals are t-based: mean ± t(0.975, n−1)·SD/√n over the participants' means "
          "(statsmodels DescrStatsW.tconfint_mean)",
    "rm_anova": "repeated-measures ANOVA with pingouin 0.7 rm_anova(correction=True) on the per-participant cell "
                "means, complete cases only; Greenhouse-Geisser epsilon and corrected p (p_GG_corr) and dfs",
    "posthoc": "task 2A: paired t-tests between all comparisons, Bonferroni-corrected over all pairs "
               "(pingouin.pairwise_tests, padjust='bonf'); the tests against the same-texture comparison are listed",
    "kendall": "Kendall's tau-b (scipy.stats.kendalltau, variant='b') of actual vs detected frequency over all "
               "identification trials (the cross table is square)",
    "quadratic_trend": "task 1: OLS (statsmodels) of the absolute deviation on angle and angle² over all trials; "
                       "the quadratic term's F test",
    "power_fit": f"task 3: {FIT_METHOD}, on the trials at levels {FIT_LEVELS[0]}..{FIT_LEVELS[-1]} (the thesis "
                 "left out levels 1 and 10, the reference spheres); non-linear least squares "
                 "(scipy.optimize.curve_fit) reported beside it",
    "outliers": f"task 4: {OUTLIER_RULE}; an outlier trial is left out of every task-4 statistic (the thesis "
                "left out the whole participant)",
    "device_comparison": "task 4: per-participant means over each device's guidance trials, paired t-test "
                         "(pingouin.ttest) and Wilcoxon signed-rank test (scipy.stats.wilcoxon)",
    "throughput": "task 4: ISO 9241-411, We = 4.133·SD of the end points along the start→target axis, "
                  "IDe = log2(Ae/We + 1), TP = IDe/MT, per condition pooled over participants "
                  "(server/analysis/fitts.py)",
    "psychophysics": psy.METHOD,
}


# What an analysis imports on first use (~1.2 s, statistics and the report): `preload` loads it ahead.
ON_FIRST_USE = ("server.analysis.report", "statsmodels.api", "statsmodels.stats.weightstats", "pingouin",
                "scipy.stats", "scipy.optimize")


def preload() -> None:
    """Import ON_FIRST_USE now. `viestac study --simulate` does it in a thread on the CPU its
    last participants leave free, so the analysis after them does not wait for it."""
    for name in ON_FIRST_USE:
        importlib.import_module(name)


def analyze(data: str | Path, out: str | Path, study: str | None = None, workers: int | None = None) -> dict:
    """Analyse the sessions in DATA (a data dir or .sqlite file) and write the outputs into OUT.
    Returns stats.json's content. Raises load.AnalysisError for data that cannot be analysed.
    workers: processes that draw the figures (default: the CPUs this process may use); the files
    are the same whatever the number."""
    dataset = load(data, study)
    stats, frames = compute(dataset)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written = write_figures(stats, frames, out / "figures", workers or len(os.sched_getaffinity(0)))
    (out / "stats.json").write_text(json.dumps(stats, indent=2, ensure_ascii=False, allow_nan=False) + "\n",
                                    encoding="utf-8")
    from server.analysis.report import render

    (out / "report.html").write_text(render(stats, written), encoding="utf-8")
    return stats


def compute(dataset: Dataset, psy_bootstrap: int = psy.BOOTSTRAP_SAMPLES) -> tuple[dict, dict]:
    """Every analysis: stats.json's content, and the frames the figures need. `psy_bootstrap`:
    resampled data sets per psychophysics fit (0: none, for callers that need the estimates only)."""
    trials = dataset.trials
    skipped: dict[str, str] = {}
    stats: dict = {"format": FORMAT, "format_version": FORMAT_VERSION, "provenance": provenance(dataset),
                   "methods": METHODS}

    def merge(prefix: str, found: dict) -> None:
        skipped.update({f"{prefix}.{k}": v for k, v in found.items()})

    stats["task1"], found = task1.analyze(task1.select(trials))
    merge("task1", found)
    stats["task2"], found = task2.analyze(task2.select_pairs(trials), task2.select_identification(trials))
    merge("task2", found)
    stats["task3"], found = task3.analyze(task3.select(trials, "estimation"), task3.select(trials, "production"))
    merge("task3", found)
    positioning = task4.select(trials)
    stats["task4"], found, kept = task4.analyze(positioning, task4.select_questionnaire(trials))
    merge("task4", found)
    stats["task4"]["throughput"] = guarded(skipped, "task4.throughput", fitts.throughput, kept, dataset.endpoints)
    psy_rows, unusable = psy.select(trials)
    stats["psychophysics"], found = psy.analyze(psy_rows, unusable, samples=psy_bootstrap)
    skipped.update(found)
    stats["skipped"] = dict(sorted(skipped.items()))
    return stats, {"task4_kept": kept, "psy_rows": psy_rows}


def provenance(dataset: Dataset) -> dict:
    sessions, trials = dataset.sessions, dataset.trials
    counts = trials.groupby(["session", "status"]).size().unstack(fill_value=0) if not trials.empty \
        else pd.DataFrame()
    rows = []
    for s in sessions.to_dict("records"):
        c = counts.loc[s["session"]] if s["session"] in counts.index else {}
        rows.append({k: s[k] for k in ("session", "participant", "participant_index", "device", "status",
                                       "created_utc", "software_version", "study_hash")}
                    | {"trials": int(sum(c.values) if len(c) else 0), "answered": int(c.get("answered", 0)),
                       "excluded": int(c.get("excluded", 0))})
    excluded = trials[trials["status"] == "excluded"]
    hashes = sorted(sessions["study_hash"].unique().tolist())
    warnings = []
    if len(hashes) > 1:
        warnings.append(f"the sessions ran {len(hashes)} different versions of the study file")
    if sessions["software_version"].nunique() > 1:
        warnings.append("the sessions were recorded by different ViESTac versions")
    return {
        "database": str(dataset.db_path),
        "study_id": sessions["study_id"].iloc[0], "study_title": sessions["study_title"].iloc[0],
        "study_hashes": hashes, "software_versions": sorted(sessions["software_version"].unique().tolist()),
        "analysis": {"viestac": __version__, "python": platform.python_version(),
                     **{lib: metadata.version(lib) for lib in LIBRARIES}},
        "n_sessions": int(len(sessions)), "n_participants": int(sessions["participant"].nunique()),
        "sessions": rows,
        "trial_status": {k: int(v) for k, v in trials["status"].value_counts().sort_index().items()},
        "excluded_trials": [{"session": t.session, "participant": t.participant, "seq": int(t.seq), "task": t.task,
                             "kind": t.kind, "reason": t.reason} for t in excluded.itertuples()],
        "warnings": warnings,
    }


def write_figures(stats: dict, frames: dict, directory: Path, workers: int = 1) -> list[dict]:
    """Draw every figure the results allow; remove figure files of an earlier run that this one
    did not draw. Returns [{name, section, title, png, svg}] in report order."""
    jobs = _figure_jobs(stats, frames)
    made = [{"name": name, "section": section, "title": title, **paths}
            for (name, section, title, _, _), paths in zip(jobs, _draw(jobs, directory, workers))]
    names = {f"{m['name']}.{ext}" for m in made for ext in ("png", "svg")}
    if directory.is_dir():
        for old in [*directory.glob("task*_*.*"), *directory.glob("psy_*.*")]:
            if old.suffix in (".png", ".svg") and old.name not in names:
                old.unlink()
    return made


def _figure_jobs(stats: dict, frames: dict) -> list[tuple]:
    """(name, section, title, make, args) of every figure the results allow, in report order."""
    jobs: list[tuple] = []

    def draw(name: str, section: str, title: str, make, *args) -> None:
        jobs.append((name, section, title, make, args))

    t1, t2, t3, t4 = (stats[k] for k in ("task1", "task2", "task3", "task4"))
    if t1["per_angle"]:
        draw("task1_angles", "task1", "Mean absolute deviation per angle with 95 % CI and quadratic trend",
             figures.task1, t1)
    if t2["pairs"]["per_comparison"]:
        draw("task2_ratings", "task2", "Mean rating per comparison with 95 % CI", figures.task2_ratings, t2["pairs"])
    if t2["identification"]["crosstab"]:
        draw("task2_crosstab", "task2", "Actual × detected frequency", figures.task2_crosstab,
             t2["identification"]["crosstab"])
    for mode in ("estimation", "production"):
        if t3[mode]["per_level"]:
            draw(f"task3_{mode}", "task3", f"Magnitude {mode}: mean per level and power law", figures.task3,
                 t3[mode], mode, t3["fit_levels"])
    devices = {d: part for d, part in t4.items() if isinstance(part, dict) and "by_cue_object" in part}
    for device, part in devices.items():
        draw(f"task4_{device}", "task4", f"{device}: trajectory length and completion time per cue and target",
             figures.task4_device, device, part)
    if any(part["helpfulness"]["n_trials"] for part in devices.values()):
        draw("task4_helpfulness", "task4", "Helpfulness ratings per cue and target", figures.task4_helpfulness,
             {d: p for d, p in devices.items() if p["helpfulness"]["n_trials"]})
    if len(devices) > 1:
        draw("task4_devices", "task4", "Device comparison", figures.task4_devices, devices)
    kept = frames["task4_kept"]
    if not kept.empty and kept["completion_time"].notna().any():
        draw("task4_speed_accuracy", "task4", "Speed-accuracy: completion time against trajectory length and "
             "end-point error", figures.speed_accuracy, kept)
    for task in stats["psychophysics"]["tasks"]:
        name = f"psy_{psy.slug(task['task'])}"
        if any(c["pooled"]["points"] for c in task["conditions"]):
            draw(f"{name}_curves", "psychophysics", f"{task['task']}: psychometric functions (points: pooled "
                 "proportions, area by trial count; thin lines: participants' fits)", figures.psy_curves, task)
        if any(cell["procedure_estimate"] is not None for c in task["conditions"] for cell in c["participants"]):
            draw(f"{name}_tracks", "psychophysics", f"{task['task']}: levels per trial (filled correct, open wrong, "
                 "rings reversals)", figures.psy_tracks, task, frames["psy_rows"])
        for cond in task["conditions"]:
            if cond["pooled"]["information"]:
                draw(f"{name}_{psy.slug(cond['condition'])}_confusion", "psychophysics",
                     f"{task['task']} {cond['condition']}: stimulus × answer", figures.psy_confusion, task, cond)
    return jobs


# The figures of one write_figures call, for the forked drawing processes (inherited, never pickled).
_shared: tuple[list[tuple], Path] | None = None


def _draw(jobs: list[tuple], directory: Path, workers: int) -> list[dict[str, Path]]:
    """The figures' files, drawn in `workers` forked processes when more than one is asked for
    and this process runs no other thread (a fork copies a lock another thread holds, locked);
    else here. Rendering (PNG and text-as-paths SVG) is most of an analysis's time."""
    global _shared
    workers = min(workers, len(jobs))
    if workers < 2 or threading.active_count() > 1 or "fork" not in multiprocessing.get_all_start_methods():
        return [_draw_one(job, directory) for job in jobs]
    _shared = (jobs, directory)
    try:
        with multiprocessing.get_context("fork").Pool(workers) as pool:
            shares = pool.map(_draw_share, [(k, workers) for k in range(workers)])
    finally:
        _shared = None
    paths: list[dict[str, Path]] = [{} for _ in jobs]
    for share in shares:
        for index, drawn in share:
            paths[index] = drawn
    return paths


def _draw_share(share: tuple[int, int]) -> list[tuple[int, dict[str, Path]]]:
    """A drawing process: every `n`-th figure from the `k`-th (the figures cost about the same)."""
    k, n = share
    jobs, directory = _shared
    return [(index, _draw_one(jobs[index], directory)) for index in range(k, len(jobs), n)]


def _draw_one(job: tuple, directory: Path) -> dict[str, Path]:
    name, _, _, make, args = job
    return figures.save(make(*args), directory, name)

