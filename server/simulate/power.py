"""`viestac study --power`: statistical power of every analysis against the number of
participants, from many simulated studies run on Dask.

For each N of the grid and each replication r < K, one simulated study of N synthetic
participants (server/simulate/study_run.py, with the effect settings of effects.py) is run and
analysed exactly as `viestac analyze` analyses it (server.analysis.run.compute, no figures); the
replication's result is the p-value of every hypothesis test (server/analysis/pvalues.py).
The power of a test at N is the share of the K replications in which it came out significant
(p < alpha; a test that could not run counts as not significant), with a Clopper-Pearson
interval (scipy.stats.binomtest).

Reproducible whatever runs it: replication (N, r)'s seed is derived from (seed, N, r) alone
(server/synthetic/rng.py), a replication is a pure function of the study text, its seed and the
settings, and the table is assembled in grid order from the stored results — never in the
order replications finish — so 1 worker, 2 workers or a remote cluster give the same table.

Resumable: every finished replication is stored at once (power_store.py); a rerun into the same
OUT computes only the missing ones (and a larger K or more N extend the grid).

Dask: a dask.distributed LocalCluster of worker processes on this machine by default
(`workers`, one thread each: the simulation is pure Python and holds the GIL); `scheduler` sends
the same tasks to an existing cluster instead (its workers need this package installed; the
study file's text travels with each task).
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import os
import tempfile
import time
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

from server.experiment.study import load_study
from server.simulate.effects import parse_settings, population
from server.simulate.power_store import ReplicationStore
from server.synthetic.rng import seed_from

ALPHA = 0.05
TARGET_POWER = 0.8       # the conventional target drawn on the chart (Cohen 1988)
FORMAT, FORMAT_VERSION = "viestac-power", 1


def replication_seed(seed: int, n: int, rep: int) -> int:
    """The seed of replication `rep` at N = `n`: 63 bits of the SHA-256 of (seed, n, rep), so it
    is the same in any process and independent of every other replication's."""
    return seed_from("power-replication", seed, n, rep) >> 65


@contextmanager
def simulated(study_text: str, study_name: str, n: int, seed: int, settings: Sequence[Sequence[str]], prefix: str):
    """One simulated study of `n` participants in a temporary directory: yields (people, result)
    while its data still exist. Everything comes in the arguments (it runs on a Dask worker)."""
    from server.simulate.study_run import simulate_study

    people = population(dict(settings))
    with tempfile.TemporaryDirectory(prefix=prefix) as tmp:
        path = Path(tmp) / "studies" / study_name
        path.parent.mkdir()
        path.write_text(study_text, encoding="utf-8")
        yield people, simulate_study(path, participants=n, seed=seed, out_dir=Path(tmp) / "run",
                                     make_participant=people.participant, agent_params=people.agent,
                                     settings=people.settings)


def run_replication(study_text: str, study_name: str, n: int, seed: int, settings: Sequence[Sequence[str]]) -> dict:
    """One simulated study of `n` participants, analysed: {"p": {test: p}, trials, aborted,
    virtual_s, wall_s}. Runs on a Dask worker: everything it needs comes in its arguments."""
    from server.analysis.load import load
    from server.analysis.pvalues import p_values
    from server.analysis.run import compute

    started = time.perf_counter()
    with simulated(study_text, study_name, n, seed, settings, "viestac-power-") as (_, result):
        stats, _ = compute(load(result.data_dir))
    return {"p": p_values(stats), "trials": result.trials, "aborted": len(result.aborted),
            "virtual_s": round(result.virtual_s, 3), "wall_s": round(time.perf_counter() - started, 3)}


@dataclass
class PowerResult:
    out: Path
    table: list[dict]
    computed: int          # replications run by this call
    reused: int            # replications found stored
    wall_s: float


def run_power(study_path: str | Path, participants: Sequence[int], replications: int, *, out: str | Path,
              seed: int = 2021, settings: Sequence[str] = (), alpha: float = ALPHA, workers: int | None = None,
              scheduler: str | None = None,
              progress: Callable[[int, int, str], None] | None = None) -> PowerResult:
    """Run the missing replications of the grid, then write OUT/power.json, power.csv and the
    chart power.png/.svg. `settings`: KEY=VALUE effect settings (effects.py)."""
    participants = sorted(set(int(n) for n in participants))
    if not participants or participants[0] < 1:
        raise ValueError(f"participants must be whole numbers >= 1, got {participants}")
    if replications < 1:
        raise ValueError(f"replications must be >= 1, got {replications}")
    if not 0 < alpha < 1:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    if workers is not None and workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    people = parse_settings(settings)                     # refuse bad settings before any work
    study_path = Path(study_path)
    study = load_study(study_path)
    text = study_path.read_text(encoding="utf-8")
    config = {"study_id": study.id, "study_sha256": study.source_hash, "seed": seed,
              "settings": [list(p) for p in people.settings]}
    out = Path(out)
    store = ReplicationStore(out / "replications.sqlite", config)
    started = time.perf_counter()
    try:
        done = store.done()
        grid = [(n, r) for n in participants for r in range(replications)]
        todo = [(n, r) for n in reversed(participants) for r in range(replications) if (n, r) not in done]
        finished = len(grid) - len(todo)
        if progress:
            progress(finished, len(grid), f"{finished} stored")
        if todo:
            with dask_client(scheduler, workers) as client:
                from distributed import as_completed

                # task keys name the whole configuration: a shared cluster never hands one run another's result
                tag = hashlib.sha256(json.dumps(config, sort_keys=True).encode()).hexdigest()[:16]
                futures = {client.submit(run_replication, text, study_path.name, n, replication_seed(seed, n, r),
                                         people.settings, key=f"viestac-power-{tag}-{n}-{r}", pure=False): (n, r)
                           for n, r in todo}
                for future in as_completed(futures):
                    n, r = futures[future]
                    store.add(n, r, replication_seed(seed, n, r), future.result())
                    finished += 1
                    if progress:
                        progress(finished, len(grid), f"N={n} #{r} · {time.perf_counter() - started:.0f} s")
        results = store.results(participants, replications)
    finally:
        store.close()
    table = power_table(results, participants, replications, alpha)
    write_outputs(out, {**config, "alpha": alpha, "participants": participants, "replications": replications},
                  table, results)
    return PowerResult(out, table, computed=len(todo), reused=len(grid) - len(todo),
                       wall_s=time.perf_counter() - started)


class dask_client:
    """A Dask client: to `scheduler`, or to a LocalCluster of `workers` processes (one thread each)."""

    def __init__(self, scheduler: str | None, workers: int | None):
        self.scheduler, self.workers = scheduler, workers
        self.cluster = self.client = None

    def __enter__(self):
        import logging

        from distributed import Client, LocalCluster

        logging.getLogger("distributed").setLevel(logging.WARNING)  # the scheduler's start/stop chatter; errors still show
        if self.scheduler:
            self.client = Client(self.scheduler)
        else:
            self.cluster = LocalCluster(n_workers=self.workers or os.cpu_count() or 1, threads_per_worker=1,
                                        processes=True, dashboard_address=":0", silence_logs=logging.ERROR)
            self.client = Client(self.cluster)
        return self.client

    def __exit__(self, *exc) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


def power_table(results: dict[tuple[int, int], dict], participants: Sequence[int], replications: int,
                alpha: float) -> list[dict]:
    """One row per test and N: replications, ran (a p was computed), significant (p < alpha),
    power (significant / replications) and its exact 95 % interval. Tests sorted by name."""
    from scipy.stats import binomtest

    tests = sorted({name for result in results.values() for name in result["p"]})
    rows = []
    for test in tests:
        for n in participants:
            ps = [results[n, r]["p"].get(test) for r in range(replications) if (n, r) in results]
            significant = sum(p is not None and p < alpha for p in ps)
            ci = binomtest(significant, len(ps)).proportion_ci(0.95, method="exact") if ps else None
            rows.append({"test": test, "n": n, "replications": len(ps), "ran": sum(p is not None for p in ps),
                         "significant": significant, "power": significant / len(ps) if ps else None,
                         "ci95": [round(ci.low, 6), round(ci.high, 6)] if ci else None})
    return rows


def write_outputs(out: Path, config: dict, table: list[dict], results: dict[tuple[int, int], dict]) -> None:
    out.mkdir(parents=True, exist_ok=True)
    doc = {"format": FORMAT, "format_version": FORMAT_VERSION, **config, "table": table,
           "virtual_s": round(sum(r["virtual_s"] for r in results.values()), 3),
           "aborted_trials": sum(r["aborted"] for r in results.values())}
    (out / "power.json").write_text(json.dumps(doc, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    with (out / "power.csv").open("w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow(["test", "n", "replications", "ran", "significant", "power", "ci95_low", "ci95_high"])
        for row in table:
            ci = row["ci95"] or [None, None]
            writer.writerow([row["test"], row["n"], row["replications"], row["ran"], row["significant"],
                             row["power"], *ci])
    chart(table, config["participants"], config["alpha"], out)


def chart(table: list[dict], participants: Sequence[int], alpha: float, out: Path) -> None:
    """power.png / power.svg: power against N, one panel per task, one line per test."""
    from matplotlib.figure import Figure

    from server.analysis.figures import save

    tasks = sorted({row["test"].split(".")[0] for row in table}) or ["(no tests)"]
    cols = min(2, len(tasks))
    rows_n = math.ceil(len(tasks) / cols)
    fig = Figure(figsize=(6.4 * cols, 4.2 * rows_n), layout="constrained")
    axes = fig.subplots(rows_n, cols, squeeze=False).ravel()
    for ax, task in zip(axes, tasks):
        tests = sorted({row["test"] for row in table if row["test"].split(".")[0] == task})
        for test in tests:
            points = [(row["n"], row["power"]) for row in table if row["test"] == test and row["power"] is not None]
            ax.plot([n for n, _ in points], [p for _, p in points], marker="o", lw=1.2,
                    label=test.removeprefix(task + "."))
        ax.axhline(TARGET_POWER, color="grey", ls="--", lw=0.8)
        ax.set_title(task)
        ax.set_xticks(list(participants))
        ax.set_ylim(-0.03, 1.03)
        ax.set_xlabel("participants (N)")
        ax.set_ylabel(f"power (share with p < {alpha:g})")
        if tests:
            ax.legend(fontsize=6, loc="best")
    for ax in axes[len(tasks):]:
        ax.set_visible(False)
    save(fig, out, "power")


def text_table(table: list[dict], participants: Sequence[int]) -> str:
    """The power table as text: one line per test, one column per N."""
    tests = sorted({row["test"] for row in table})
    power = {(row["test"], row["n"]): row["power"] for row in table}
    width = max([len(t) for t in tests] + [4])
    lines = [f"{'test':{width}s} " + " ".join(f"N={n:<4d}" for n in participants)]
    for test in tests:
        cells = [power.get((test, n)) for n in participants]
        lines.append(f"{test:{width}s} " + " ".join(f"{c:6.2f}" if c is not None else "     -" for c in cells))
    return "\n".join(lines)
