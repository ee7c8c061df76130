"""`viestac bench psychophysics`: issue 36's acceptance numbers for the psychophysics core, each
from simulated observers with a fixed seed (docs/psychophysics.md "Acceptance numbers").
tests/psychophysics/ run the same experiments on bounded samples.

- staircases: 1-up/2-down, 1-up/3-down and weighted up-down (p = 0.75, 0.9) over many runs; the
  observer's probability at the mean estimate against the target.
- QUEST+ after 40 trials against 1-up/3-down after 80, the same 2AFC observers: RMS error of
  what each estimates (QUEST+: the threshold; the staircase: its 79.4 % level).
- QUEST+'s next-stimulus choice on a 50×50×6 parameter grid with 50 levels: p50/p99/max.
- the parametric bootstrap's 95 % threshold interval: how often it covers the true threshold.
- information transfer: the bias of the plug-in and Miller–Madow estimates on small samples.
"""

from __future__ import annotations

import time

import numpy as np

from server.psychophysics.fit import bootstrap, fit
from server.psychophysics.information import from_distribution, information_transfer
from server.psychophysics.observer import PsychometricObserver
from server.psychophysics.procedures import parse_procedure
from server.psychophysics.questplus import QuestPlus, QuestPlusSpec
from server.psychophysics.simulate import run

# the staircases' observer: 2AFC, a Weibull on dB levels (Gumbel), threshold 10 dB; its slope
# (0.2 per dB: 60 % to 90 % correct over ~10 dB) is five times the last step of 1 dB, small steps
# against the spread being what Levitt's convergence points assume (docs/psychophysics.md)
STAIRCASE_OBSERVER = PsychometricObserver(threshold=10.0, slope=0.2, guess=0.5, lapse=0.0, family="gumbel")
STAIRCASES = {
    "1-up/2-down": {"kind": "up-down", "up": 1, "down": 2, "start": 20.0, "steps": [4, 2, 1],
                    "max_reversals": 16, "average": 12},
    "1-up/3-down": {"kind": "up-down", "up": 1, "down": 3, "start": 20.0, "steps": [4, 2, 1],
                    "max_reversals": 16, "average": 12},
    "weighted 0.75": {"kind": "weighted-up-down", "target": 0.75, "guess": 0.5, "start": 20.0, "steps": [1, 0.5],
                      "max_reversals": 24, "average": 16},
    "weighted 0.9": {"kind": "weighted-up-down", "target": 0.9, "guess": 0.5, "start": 20.0,
                     "steps": [0.5, 0.25], "max_reversals": 24, "average": 16},
}


def staircase_convergence(name: str, runs: int, seed: int = 1) -> dict:
    spec = parse_procedure(STAIRCASES[name])
    rng = np.random.default_rng(seed)
    estimates, trials = [], []
    for i in range(runs):
        procedure, track = run(spec, STAIRCASE_OBSERVER, rng, seed=i)
        estimates.append(procedure.estimate())
        trials.append(len(track))
    mean = float(np.mean(estimates))
    p = float(STAIRCASE_OBSERVER.probability(mean))
    return {"runs": runs, "target": spec.target, "mean_estimate_db": mean, "p_at_mean": p,
            "error_points": 100.0 * (p - spec.target), "mean_trials": float(np.mean(trials))}


def quest_grid_spec(thresholds=50, slopes=50, lapses=6, levels=50, max_trials=40, slope_range=(0.1, 0.4)) -> QuestPlusSpec:
    return QuestPlusSpec.parse({
        "kind": "quest-plus", "family": "gumbel", "max_trials": max_trials,
        "levels": {"from": -10.0, "to": 30.0, "count": levels},
        "threshold": {"from": -10.0, "to": 30.0, "count": thresholds},
        "slope": {"from": slope_range[0], "to": slope_range[1], "count": slopes, "spacing": "log"},
        "guess": 0.5, "lapse": np.linspace(0.0, 0.05, lapses).tolist() if lapses > 1 else [0.02]})


def quest_against_staircase(observers: int, seed: int = 2, grid: QuestPlusSpec | None = None,
                            focus: tuple = ("threshold",), slopes: tuple = (0.25, 0.25)) -> dict:
    """The same 2AFC observers (threshold uniform in 0–20 dB, slope uniform in `slopes` per dB,
    lapse uniform in 0–4 %) run by QUEST+ for 40 trials and by 1-up/3-down for 80 (its answers
    drawn from a generator of its own). QUEST+'s grid spans what the lab knows of such observers
    (threshold −10–30 dB, slope 0.1–0.4, lapse 0–5 %, a uniform prior: none of them is given to it)
    and it chooses for the threshold's marginal entropy (psi-marginal; slope and lapse are
    nuisances). Errors: QUEST+'s threshold estimate against the threshold, the staircase's
    estimate against the level it converges to (79.4 %)."""
    who, quest_answers, staircase_answers = (np.random.default_rng([seed, i]) for i in range(3))
    spec = grid or quest_grid_spec()
    quest_grid = spec.grid()
    staircase = parse_procedure({"kind": "up-down", "up": 1, "down": 3, "start": 25.0, "steps": [4, 2, 1],
                                 "max_trials": 80, "average": 8})
    q_err, s_err = [], []
    for i in range(observers):
        obs = PsychometricObserver(float(who.uniform(0, 20)), float(who.uniform(*slopes)), 0.5,
                                   float(who.uniform(0, 0.04)), "gumbel")
        quest = QuestPlus(quest_grid, 40, "mean", focus)
        while not quest.finished:
            quest.update(bool(quest_answers.random() < obs.probability(quest.level)))
        q_err.append(quest.estimates()["threshold"] - obs.threshold)
        procedure, _ = run(staircase, obs, staircase_answers, seed=i)
        s_err.append(procedure.estimate() - obs.level_at(staircase.target))
    q_abs, s_abs = np.abs(q_err), np.abs(s_err)
    return {"observers": observers, "slopes": list(slopes), "quest_plus_40_bias_db": float(np.mean(q_err)),
            "quest_plus_40_abs_p50_p90_db": np.percentile(q_abs, [50, 90]).tolist(),
            "up_down_1_3_80_abs_p50_p90_db": np.percentile(s_abs, [50, 90]).tolist(),
            "up_down_1_3_80_bias_db": float(np.mean(s_err)), "quest_plus_40_rms_db": float(np.sqrt(np.mean(np.square(q_err)))),
            "up_down_1_3_80_rms_db": float(np.sqrt(np.mean(np.square(s_err))))}


def quest_choice_time(choices: int, seed: int = 3, focus: tuple = ()) -> dict:
    """Wall time of `update` (posterior update plus the next choice) on the 50×50×6 grid; `focus`:
    the psi-marginal choice for those parameters (else the joint entropy)."""
    spec = quest_grid_spec(max_trials=10**9)
    t0 = time.perf_counter()
    grid = spec.grid()
    if focus:
        grid.marginal_table(focus)
    build_s = time.perf_counter() - t0
    rng = np.random.default_rng(seed)
    times, cpu = [], []
    while len(times) < choices:
        obs = PsychometricObserver(float(rng.uniform(0, 20)), 0.2, 0.5, 0.02, "gumbel")
        quest = QuestPlus(grid, 50, "mean", focus)
        while not quest.finished and len(times) < choices:
            answer = bool(rng.random() < obs.probability(quest.level))
            t, c = time.perf_counter(), time.thread_time()
            quest.update(answer)
            times.append(time.perf_counter() - t)
            cpu.append(time.thread_time() - c)  # the call's own CPU time: without the waits of a loaded machine
    ms, cpu_ms = np.asarray(times) * 1e3, np.asarray(cpu) * 1e3
    return {"choices": choices, "grid": [50, 50, 6], "levels": 50, "focus": list(focus), "table_build_s": build_s,
            "p50_ms": float(np.percentile(ms, 50)), "p99_ms": float(np.percentile(ms, 99)), "max_ms": float(ms.max()),
            "cpu_p50_ms": float(np.percentile(cpu_ms, 50)), "cpu_p99_ms": float(np.percentile(cpu_ms, 99))}


# the fits' observer and design: 2AFC, 7 levels × 40 trials (Weibull, lapse fitted within 6 %)
FIT_OBSERVER = PsychometricObserver(threshold=1.0, slope=3.0, guess=0.5, lapse=0.01, family="weibull")
FIT_LEVELS = np.geomspace(0.5, 2.0, 7)
FIT_TRIALS = np.full(7, 40)


def bootstrap_coverage(data_sets: int, samples: int, seed: int = 4) -> dict:
    rng = np.random.default_rng(seed)
    covered, widths = 0, []
    for _ in range(data_sets):
        k = rng.binomial(FIT_TRIALS, FIT_OBSERVER.probability(FIT_LEVELS))
        result = fit(FIT_LEVELS, FIT_TRIALS, k, "weibull", 0.5, 0.06)
        lo, hi = bootstrap(result, FIT_LEVELS, FIT_TRIALS, rng, samples).threshold_ci
        covered += lo <= FIT_OBSERVER.threshold <= hi
        widths.append(hi - lo)
    return {"data_sets": data_sets, "bootstrap_samples": samples, "coverage": covered / data_sets,
            "median_width": float(np.median(widths))}


# identification of 4 stimuli, 60 % correct, errors spread evenly, 10 presentations each (N = 40)
IT_CHANNEL = np.full((4, 4), 0.4 / 3) + np.eye(4) * (0.6 - 0.4 / 3)


def information_bias(matrices: int, per_stimulus: int = 10, seed: int = 5) -> dict:
    rng = np.random.default_rng(seed)
    truth = from_distribution(IT_CHANNEL)
    ml, corrected = [], []
    for _ in range(matrices):
        counts = np.stack([rng.multinomial(per_stimulus, row) for row in IT_CHANNEL])
        it = information_transfer(counts)
        ml.append(it.bits)
        corrected.append(it.corrected)
    return {"matrices": matrices, "trials": per_stimulus * len(IT_CHANNEL), "true_bits": truth,
            "ml_bias_bits": float(np.mean(ml) - truth), "corrected_bias_bits": float(np.mean(corrected) - truth),
            "corrected_rmse_bits": float(np.sqrt(np.mean((np.asarray(corrected) - truth) ** 2))),
            "ml_rmse_bits": float(np.sqrt(np.mean((np.asarray(ml) - truth) ** 2)))}


def run_psychophysics_bench(quick: bool = False) -> dict:
    scale = 10 if quick else 1
    t0 = time.perf_counter()
    result = {
        "staircases": {name: staircase_convergence(name, 2000 // scale) for name in STAIRCASES},
        "quest_vs_staircase": quest_against_staircase(500 // scale),
        "quest_vs_staircase_slopes_vary": quest_against_staircase(500 // scale, slopes=(0.15, 0.3)),
        "quest_choice": quest_choice_time(1000 if not quick else 200),
        "quest_choice_marginal": quest_choice_time(1000 if not quick else 200, focus=("threshold",)),
        "bootstrap": bootstrap_coverage(500 // scale, 1000 // (2 if quick else 1)),
        "information": information_bias(5000 // scale),
    }
    result["seconds"] = time.perf_counter() - t0
    return result
