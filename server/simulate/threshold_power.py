"""`viestac study --power` for a psychophysics study: how many trials for a threshold standard
error of 1 dB? (docs/power.md, "Psychophysics")

Each replication is one simulated study of N synthetic participants through the real engine
(server/simulate/study_run.py: the engine picks every level, the psychometric participant of
server/synthetic answers). For every participant, psychophysics task and condition it keeps the
participant's true threshold (psychometric.py: the threshold α of its own function) and the
procedure's estimate after each of the task's trials (Contract C3: `metrics["psy"]["estimate"]`;
a constant-stimuli procedure has none, so the first T trials are fitted instead, fit.py). Since
the next level is a pure function of the answers so far, the first T trials of a task of
max_trials are exactly a task of T trials: one simulated study gives the estimate at every
count T of the grid.

Per task, condition and T over all K·N simulated participants: the error of the estimate
(estimate − true; in dB, 20·log10(estimate / true), where the driven parameter is an amplitude),
its bias (mean), standard error (SD) with a 95 % chi-square interval, and RMS; then the smallest
T whose SE meets the target (`--target-se-db`, default 1 dB).

Replications run on Dask and are stored as they finish (power.py's machinery: seeds from
(seed, N, r) alone, resumable, the same table with any number of workers).
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import sqlite3
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping, Sequence

from server.experiment.study import load_study
from server.simulate.effects import parse_settings
from server.simulate.power import dask_client, replication_seed, simulated
from server.simulate.power_store import ReplicationStore
from server.simulate.study_run import stimulus_of
from server.synthetic.psychometric import AMPLITUDE_PARAMETERS, PsyAnswerError

TARGET_SE_DB = 1.0
FORMAT, FORMAT_VERSION = "viestac-threshold-power", 1
MAIN = "main"  # the condition name of a task without interleaved conditions (Contract C4)


def psychophysics_tasks(study_text: str) -> dict[str, int]:
    """{task id: max_trials} of the study's psychophysics tasks (Contract C2's
    `[tasks.psychophysics]` tables), in file order."""
    tasks = tomllib.loads(study_text).get("tasks", [])
    return {str(t["id"]): int(t["psychophysics"].get("max_trials", 0)) for t in tasks
            if isinstance(t, Mapping) and isinstance(t.get("psychophysics"), Mapping)}


def default_trials(max_trials: int) -> list[int]:
    """A quarter, half, three quarters and all of max_trials."""
    return sorted({max(1, round(max_trials * f)) for f in (0.25, 0.5, 0.75, 1.0)})


# ---- one replication ------------------------------------------------------------------------------

def run_threshold_replication(study_text: str, study_name: str, n: int, seed: int,
                              settings: Sequence[Sequence[str]]) -> dict:
    """One simulated study of `n` participants: every psychophysics track with its true
    threshold. Runs on a Dask worker: everything it needs comes in its arguments."""
    started = time.perf_counter()
    with simulated(study_text, study_name, n, seed, settings, "viestac-threshold-power-") as (people, result):
        observers = tracks(result.data_dir / "viestac.sqlite", lambda index: people.participant(seed, index))
    return {"observers": observers, "trials": result.trials, "aborted": len(result.aborted),
            "virtual_s": round(result.virtual_s, 3), "wall_s": round(time.perf_counter() - started, 3)}


def tracks(db: Path, participant: Callable[[int], object]) -> list[dict]:
    """Every (participant, psychophysics task, condition) of a simulated study's database: its
    design, parameter, unit, true threshold and track [[task trial t, level, correct, estimate], ...]
    (t counts the task's answered trials from 1, across its conditions)."""
    con = sqlite3.connect(db)
    try:
        rows = con.execute("""
            SELECT s.participant_index, t.task, t.device, t.params_json, t.scenario_params_json, t.metrics_json
            FROM trials t JOIN sessions s ON s.id = t.session_id
            WHERE t.status = 'answered' AND t.kind = 'main'
            ORDER BY s.participant_index, t.seq""").fetchall()
    finally:
        con.close()
    observers: dict[tuple, dict] = {}
    counts: dict[tuple, int] = {}
    for index, task, device, params, scenario_params, metrics in rows:
        psy = json.loads(metrics).get("psy")
        if not psy:
            continue
        counts[index, task] = t = counts.get((index, task), 0) + 1
        condition = psy.get("condition") or MAIN
        key = (index, task, condition)
        if key not in observers:
            stimulus = stimulus_of({"device": device, "params": json.loads(params),
                                    "scenario_params": json.loads(scenario_params)})
            observers[key] = {"participant": index, "task": task, "condition": condition,
                              "design": psy.get("design"), "parameter": psy.get("parameter"),
                              "unit": psy.get("unit"), "guess": psy.get("guess"),
                              "true": _true_threshold(participant(index), psy, stimulus), "track": []}
        observers[key]["track"].append([t, psy.get("level"), psy.get("correct"), _estimate_of(psy, condition)])
    return list(observers.values())


def _true_threshold(person, psy: Mapping, stimulus: Mapping) -> float | None:
    """The participant's own threshold for this task (None: a design with no threshold)."""
    if psy.get("design") == "identification":
        return None
    try:
        return person.psychometric.threshold(psy["parameter"], psy.get("reference"), stimulus)
    except PsyAnswerError:
        return None


def _estimate_of(psy: Mapping, condition: str) -> float | None:
    """The procedure's threshold estimate after this answer: a number; an interleaved procedure's
    {condition: estimate}; QUEST+'s {threshold: …, slope: …}; or None."""
    estimate = psy.get("estimate")
    if isinstance(estimate, Mapping):
        estimate = estimate.get(condition, estimate.get("threshold"))
        if isinstance(estimate, Mapping):
            estimate = estimate.get("threshold")
    return float(estimate) if isinstance(estimate, (int, float)) and math.isfinite(estimate) else None


# ---- the table ------------------------------------------------------------------------------------

def estimate_at(observer: Mapping, trials: int) -> float | None:
    """The estimate after the task's first `trials` trials: the procedure's own, else (constant
    stimuli) a maximum-likelihood fit of those trials."""
    track = [row for row in observer["track"] if row[0] <= trials]
    estimates = [row[3] for row in track if row[3] is not None]
    if estimates:
        return estimates[-1]
    answered = [(row[1], row[2]) for row in track if row[1] is not None and row[2] is not None]
    if len({level for level, _ in answered}) < 2:
        return None
    from server.psychophysics.fit import fit

    levels = sorted({level for level, _ in answered})
    n = [sum(1 for lv, _ in answered if lv == level) for level in levels]
    k = [sum(1 for lv, c in answered if lv == level and c) for level in levels]
    family = "weibull" if levels[0] > 0 else "logistic"
    result = fit(levels, n, k, family=family, guess=float(observer.get("guess") or 0.0))
    # data a step fits perfectly stop at the slope bound unconverged, their threshold still between
    # the two levels that bracket it: kept; a threshold outside the tested levels is not an estimate
    inside = levels[0] <= result.threshold <= levels[-1]
    return float(result.threshold) if math.isfinite(result.threshold) and inside else None


def error_of(observer: Mapping, estimate: float) -> float | None:
    """estimate − true, in dB for an amplitude parameter (None where it has no such value)."""
    true = observer["true"]
    if true is None:
        return None
    if observer["parameter"] in AMPLITUDE_PARAMETERS:
        return 20.0 * math.log10(estimate / true) if estimate > 0 and true > 0 else None
    return estimate - true


def threshold_table(observers: Sequence[Mapping], trials: Sequence[int], target_se_db: float = TARGET_SE_DB) -> dict:
    """{"rows": one per task, condition and T; "summary": one per task and condition with the
    smallest T whose SE meets the target (amplitude parameters, in dB)}."""
    from scipy.stats import chi2

    groups: dict[tuple[str, str], list[Mapping]] = {}
    for observer in observers:
        groups.setdefault((observer["task"], observer["condition"]), []).append(observer)
    rows, summary = [], []
    for (task, condition), members in sorted(groups.items()):
        first = members[0]
        amplitude = first["parameter"] in AMPLITUDE_PARAMETERS
        scale = "dB" if amplitude else (first.get("unit") or "")
        meets = None
        for count in trials:
            errors = []
            for observer in members:
                estimate = estimate_at(observer, count)
                error = error_of(observer, estimate) if estimate is not None else None
                if error is not None:
                    errors.append(error)
            m = len(errors)
            bias = sum(errors) / m if m else None
            se = math.sqrt(sum((e - bias) ** 2 for e in errors) / (m - 1)) if m > 1 else None
            ci = ([round(se * math.sqrt((m - 1) / chi2.ppf(0.975, m - 1)), 6),
                   round(se * math.sqrt((m - 1) / chi2.ppf(0.025, m - 1)), 6)] if se is not None else None)
            rmse = math.sqrt(sum(e * e for e in errors) / m) if m else None
            rows.append({"task": task, "condition": condition, "design": first["design"],
                         "parameter": first["parameter"], "scale": scale, "trials": count,
                         "observers": len(members), "estimated": m, "bias": _round(bias), "se": _round(se),
                         "se_ci95": ci, "rmse": _round(rmse)})
            if meets is None and amplitude and se is not None and se <= target_se_db:
                meets = count
        summary.append({"task": task, "condition": condition, "parameter": first["parameter"], "scale": scale,
                        "target_se": target_se_db if amplitude else None, "trials_for_target": meets})
    return {"rows": rows, "summary": summary}


def _round(x: float | None) -> float | None:
    return None if x is None else round(x, 6)


# ---- the run --------------------------------------------------------------------------------------

@dataclass
class ThresholdPowerResult:
    out: Path
    table: dict
    trials: list[int]
    computed: int
    reused: int
    wall_s: float


def run_threshold_power(study_path: str | Path, participants: int, replications: int, *, out: str | Path,
                        trials: Sequence[int] | None = None, target_se_db: float = TARGET_SE_DB, seed: int = 2021,
                        settings: Sequence[str] = (), workers: int | None = None, scheduler: str | None = None,
                        progress: Callable[[int, int, str], None] | None = None) -> ThresholdPowerResult:
    """Run the missing replications, then write OUT/threshold_power.json, .csv and the chart."""
    if participants < 1 or replications < 1:
        raise ValueError(f"participants and replications must be >= 1, got {participants} and {replications}")
    if not target_se_db > 0:
        raise ValueError(f"--target-se-db must be > 0, got {target_se_db}")
    if workers is not None and workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    people = parse_settings(settings)
    study_path = Path(study_path)
    study = load_study(study_path)
    text = study_path.read_text(encoding="utf-8")
    tasks = psychophysics_tasks(text)
    if not tasks:
        raise ValueError(f"{study_path.name}: no task has a [tasks.psychophysics] table: nothing to estimate")
    shortest = min(tasks.values())
    trials = sorted(set(int(t) for t in trials)) if trials else default_trials(shortest)
    if trials[0] < 1 or trials[-1] > shortest:
        short = min(tasks, key=tasks.get)
        raise ValueError(f"--trials must lie in 1..{shortest} (task {short!r}: max_trials = {shortest}; the engine "
                         f"reserves no more), got {trials}")
    config = {"mode": "threshold", "study_id": study.id, "study_sha256": study.source_hash, "seed": seed,
              "settings": [list(p) for p in people.settings], "participants": participants}
    out = Path(out)
    store = ReplicationStore(out / "replications.sqlite", config)
    started = time.perf_counter()
    try:
        done = store.done()
        todo = [r for r in range(replications) if (participants, r) not in done]
        finished = replications - len(todo)
        if progress:
            progress(finished, replications, f"{finished} stored")
        if todo:
            with dask_client(scheduler, workers) as client:
                from distributed import as_completed

                tag = hashlib.sha256(json.dumps(config, sort_keys=True).encode()).hexdigest()[:16]
                futures = {client.submit(run_threshold_replication, text, study_path.name, participants,
                                         replication_seed(seed, participants, r), people.settings,
                                         key=f"viestac-threshold-power-{tag}-{r}", pure=False): r for r in todo}
                for future in as_completed(futures):
                    r = futures[future]
                    store.add(participants, r, replication_seed(seed, participants, r), future.result())
                    finished += 1
                    if progress:
                        progress(finished, replications, f"#{r} · {time.perf_counter() - started:.0f} s")
        results = store.results([participants], replications)
    finally:
        store.close()
    observers = [o for (_, r), result in results.items() for o in result["observers"]]
    table = threshold_table(observers, trials, target_se_db)
    doc = {"format": FORMAT, "format_version": FORMAT_VERSION, **config, "replications": replications,
           "trials": trials, "target_se_db": target_se_db, **table,
           "virtual_s": round(sum(r["virtual_s"] for r in results.values()), 3),
           "aborted_trials": sum(r["aborted"] for r in results.values())}
    write_outputs(out, doc)
    return ThresholdPowerResult(out, table, trials, computed=len(todo), reused=replications - len(todo),
                                wall_s=time.perf_counter() - started)


def write_outputs(out: Path, doc: dict) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / "threshold_power.json").write_text(json.dumps(doc, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    columns = ["task", "condition", "design", "parameter", "scale", "trials", "observers", "estimated", "bias",
               "se", "rmse"]
    with (out / "threshold_power.csv").open("w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow([*columns, "se_ci95_low", "se_ci95_high"])
        for row in doc["rows"]:
            writer.writerow([*(row[c] for c in columns), *(row["se_ci95"] or [None, None])])
    chart(doc, out)


def chart(doc: dict, out: Path) -> None:
    """threshold_power.png / .svg: the threshold's SE against the number of trials, one line per
    task and condition; the dashed line is the target."""
    from matplotlib.figure import Figure

    from server.analysis.figures import save

    fig = Figure(figsize=(6.4, 4.2), layout="constrained")
    ax = fig.subplots()
    for entry in doc["summary"]:
        points = [(r["trials"], r["se"]) for r in doc["rows"] if r["task"] == entry["task"]
                  and r["condition"] == entry["condition"] and r["se"] is not None]
        label = entry["task"] if entry["condition"] == MAIN else f"{entry['task']} · {entry['condition']}"
        ax.plot([t for t, _ in points], [s for _, s in points], marker="o", lw=1.2,
                label=f"{label} ({entry['scale'] or entry['parameter']})")
    ax.axhline(doc["target_se_db"], color="grey", ls="--", lw=0.8)
    ax.set_xticks(doc["trials"])
    ax.set_xlabel("trials per task")
    ax.set_ylabel("threshold standard error")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=7, loc="best")
    save(fig, out, "threshold_power")


def text_table(table: dict, trials: Sequence[int]) -> str:
    """SE per task and condition (one column per T), then the trials that meet the target."""
    width = max([len(f"{s['task']} · {s['condition']}") for s in table["summary"]] + [10])
    lines = [f"{'task · condition':{width}s} unit " + " ".join(f"T={t:<5d}" for t in trials) + " meets target at"]
    for entry in table["summary"]:
        se = {r["trials"]: r["se"] for r in table["rows"]
              if r["task"] == entry["task"] and r["condition"] == entry["condition"]}
        cells = " ".join(f"{se[t]:7.2f}" if se.get(t) is not None else "      -" for t in trials)
        meets = (f"{entry['trials_for_target']} trials" if entry["trials_for_target"] is not None else
                 ("not within the grid" if entry["target_se"] is not None else "(no target: not an amplitude)"))
        lines.append(f"{entry['task'] + ' · ' + entry['condition']:{width}s} {entry['scale'] or '-':4s} {cells} {meets}")
    return "\n".join(lines)
