"""The statistics against independent reference values: small hand-made datasets whose results are
computed here another way (textbook formulas with numpy, pair counting, numpy.polyfit), never with
the library call the analysis uses."""

from __future__ import annotations

import itertools
import math
from collections import Counter

import numpy as np
import pandas as pd
import pytest
from scipy import stats as sps

from server.analysis import fitts, task1, task2, task3, task4
from server.analysis.stats import describe

# 5 participants × 4 angles, absolute deviations (hand-made, unequal variances)
DEV = np.array([[2.0, 5.0, 9.0, 14.0],
                [3.0, 4.0, 12.0, 10.0],
                [1.0, 7.0, 8.0, 19.0],
                [4.0, 6.0, 15.0, 11.0],
                [2.0, 3.0, 10.0, 22.0]])
ANGLES = (10.0, 30.0, 50.0, 70.0)


def angle_frame(dev=DEV, angles=ANGLES) -> pd.DataFrame:
    rows = [(i * 10 + j, f"P{i}", a, a + d, d, d)
            for i, row in enumerate(dev) for j, (a, d) in enumerate(zip(angles, row))]
    return pd.DataFrame(rows, columns=task1.COLUMNS)


def textbook_rm_anova(y: np.ndarray) -> dict:
    """One-way repeated-measures ANOVA and Greenhouse-Geisser epsilon from the formulas (n × k)."""
    n, k = y.shape
    gm = y.mean()
    ss_cond = n * ((y.mean(axis=0) - gm) ** 2).sum()
    ss_subj = k * ((y.mean(axis=1) - gm) ** 2).sum()
    ss_err = ((y - gm) ** 2).sum() - ss_cond - ss_subj
    df1, df2 = k - 1, (k - 1) * (n - 1)
    f = (ss_cond / df1) / (ss_err / df2)
    s = np.cov(y, rowvar=False)                              # k × k covariance of the levels
    dc = s - s.mean(axis=0) - s.mean(axis=1)[:, None] + s.mean()  # double-centred
    eps = np.trace(dc) ** 2 / ((k - 1) * (dc ** 2).sum())     # Greenhouse & Geisser (1959) / Box (1954)
    return {"F": f, "df1": df1, "df2": df2, "eps": eps, "p_unc": sps.f.sf(f, df1, df2),
            "p_gg": sps.f.sf(f, eps * df1, eps * df2)}


def test_rm_anova_matches_the_textbook_formulas():
    section, skipped = task1.analyze(angle_frame())
    ref = textbook_rm_anova(DEV)
    r = section["rm_anova"]
    assert not skipped
    assert r["F"] == pytest.approx(ref["F"], rel=1e-9)
    assert (r["ddof1"], r["ddof2"]) == (ref["df1"], ref["df2"])
    assert r["eps"] == pytest.approx(ref["eps"], rel=1e-9)
    assert r["p_unc"] == pytest.approx(ref["p_unc"], rel=1e-9)
    assert r["p_gg"] == pytest.approx(ref["p_gg"], rel=1e-9)
    assert r["ddof1_gg"] == pytest.approx(ref["eps"] * 3) and r["ddof2_gg"] == pytest.approx(ref["eps"] * 12)


def test_confidence_interval_is_the_t_interval():
    x = DEV[:, 2]
    half = sps.t.ppf(0.975, len(x) - 1) * x.std(ddof=1) / math.sqrt(len(x))
    d = describe(pd.DataFrame({"participant": list("abcde"), "v": x}), "v")
    assert (d["mean"], d["sd"]) == (pytest.approx(x.mean()), pytest.approx(x.std(ddof=1)))
    assert d["ci95_low"] == pytest.approx(x.mean() - half) and d["ci95_high"] == pytest.approx(x.mean() + half)


def test_quadratic_trend_matches_least_squares_by_hand():
    frame = angle_frame(np.array([[9.0, 3.0, 4.0, 12.0], [11.0, 2.0, 5.0, 8.0], [7.0, 4.0, 2.0, 15.0]]),
                        (-70.0, -10.0, 30.0, 90.0))
    q = task1.quadratic_trend(frame)
    x, y = frame["angle"].to_numpy(), frame["abs_dev"].to_numpy()
    design = np.column_stack([np.ones_like(x), x, x ** 2])
    beta, *_ = np.linalg.lstsq(design, y, rcond=None)
    n = len(y)
    sigma2 = ((y - design @ beta) ** 2).sum() / (n - 3)
    var_b2 = sigma2 * np.linalg.inv(design.T @ design)[2, 2]
    f_quad = beta[2] ** 2 / var_b2
    assert [q["b0"], q["b1"], q["b2"]] == pytest.approx(beta, rel=1e-9)
    assert q["F_quadratic"] == pytest.approx(f_quad, rel=1e-9)
    assert q["p_quadratic"] == pytest.approx(sps.f.sf(f_quad, 1, n - 3), rel=1e-9)
    assert q["df_quadratic"] == [1, n - 3]


def kendall_by_counting(x, y) -> tuple[float, float]:
    """tau-b from concordant/discordant pairs, and the tie-corrected normal-approximation p
    (Kendall 1970: var = (v0 − vt − vu)/18 + v1 + v2)."""
    n = len(x)
    c = d = tx = ty = 0
    for i, j in itertools.combinations(range(n), 2):
        sx, sy = np.sign(x[i] - x[j]), np.sign(y[i] - y[j])
        tx += sx == 0
        ty += sy == 0
        c += sx * sy > 0
        d += sx * sy < 0
    n0 = n * (n - 1) / 2
    tau = (c - d) / math.sqrt((n0 - tx) * (n0 - ty))
    t, u = Counter(x).values(), Counter(y).values()
    v0 = n * (n - 1) * (2 * n + 5)
    vt = sum(k * (k - 1) * (2 * k + 5) for k in t)
    vu = sum(k * (k - 1) * (2 * k + 5) for k in u)
    v1 = sum(k * (k - 1) for k in t) * sum(k * (k - 1) for k in u) / (2 * n * (n - 1))
    v2 = sum(k * (k - 1) * (k - 2) for k in t) * sum(k * (k - 1) * (k - 2) for k in u) / (9 * n * (n - 1) * (n - 2))
    z = (c - d) / math.sqrt((v0 - vt - vu) / 18 + v1 + v2)
    return tau, 2 * sps.norm.sf(abs(z))


IDENT = [(500.0, 500.0), (500.0, 333.33), (333.33, 250.0), (333.33, 333.33), (250.0, 333.33), (250.0, 250.0),
         (200.0, 250.0), (200.0, 166.67), (166.67, 166.67), (166.67, 200.0), (500.0, 500.0), (250.0, 200.0)]


def ident_frame(pairs=IDENT) -> pd.DataFrame:
    return pd.DataFrame([(i, f"P{i % 3}", a, d) for i, (a, d) in enumerate(pairs)], columns=task2.IDENT_COLUMNS)


def test_kendall_tau_b_matches_pair_counting_and_the_crosstab_matches_counting():
    section, _ = task2.analyze(pd.DataFrame(columns=task2.PAIR_COLUMNS), ident_frame())
    tau, p = kendall_by_counting([a for a, _ in IDENT], [d for _, d in IDENT])
    assert section["kendall_tau_variant"] == "tau-b"
    assert section["kendall_tau"] == pytest.approx(tau, rel=1e-12)
    assert section["kendall_tau_p"] == pytest.approx(p, rel=1e-9)
    ct = section["identification"]["crosstab"]
    counts = Counter(IDENT)
    for i, a in enumerate(ct["actual_hz"]):
        for j, d in enumerate(ct["detected_hz"]):
            assert ct["counts"][i][j] == counts[(a, d)]
    assert ct["accuracy"] == pytest.approx(sum(a == d for a, d in IDENT) / len(IDENT))


def test_kendall_tau_is_one_without_confusion_and_falls_as_confusion_grows():
    rng = np.random.default_rng(3)
    choices = np.array([500.0, 333.33, 250.0, 200.0, 166.67])
    taus = []
    for confusion in (0.0, 0.15, 0.4):
        pairs = []
        for _ in range(13):
            for f in choices:
                seen = f * math.exp(rng.normal(0, confusion)) if confusion else f
                pairs.append((f, float(choices[np.argmin(abs(np.log(choices / seen)))])))
        taus.append(task2.analyze(pd.DataFrame(columns=task2.PAIR_COLUMNS), ident_frame(pairs))[0]["kendall_tau"])
    assert taus[0] == pytest.approx(1.0)
    assert taus[0] > taus[1] > taus[2]


def test_bonferroni_posthoc_matches_paired_t_by_hand():
    ratings = {"166.67 vs 250 Hz": [7, 6, 7, 6, 5], "250 vs 250 Hz": [4, 4, 5, 4, 3], "500 vs 250 Hz": [2, 1, 2, 3, 1]}
    rows = [(0, f"P{i}", 250.0, float(label.split()[0]), label, float(v))
            for label, vals in ratings.items() for i, v in enumerate(vals)]
    section, _ = task2.analyze(pd.DataFrame(rows, columns=task2.PAIR_COLUMNS), ident_frame())
    post = section["pairs"]["posthoc"]
    assert section["pairs"]["reference"] == "250 vs 250 Hz" and post["n_pairs_corrected"] == 3
    for test in post["tests"]:
        d = np.array(ratings[test["comparison"]], float) - np.array(ratings["250 vs 250 Hz"], float)
        t = d.mean() / (d.std(ddof=1) / math.sqrt(len(d)))
        p = 2 * sps.t.sf(abs(t), len(d) - 1)
        assert abs(test["T"]) == pytest.approx(abs(t), rel=1e-9)
        assert test["p_unc"] == pytest.approx(p, rel=1e-9)
        assert test["p_bonf"] == pytest.approx(min(1.0, 3 * p), rel=1e-9)
        assert test["mean_diff"] == pytest.approx(d.mean())


def stiffness_frame(a, b, noise=None) -> pd.DataFrame:
    levels = np.tile(np.arange(1, 11), 4)
    values = a * levels.astype(float) ** b * (np.exp(noise) if noise is not None else 1.0)
    return pd.DataFrame([(i, f"P{i // 10}", float(s), float(v), None) for i, (s, v) in enumerate(zip(levels, values))],
                        columns=task3.COLUMNS)


def test_power_law_recovers_exact_data_and_matches_polyfit_on_logs():
    exact = task3.power_fit(stiffness_frame(1.164, 0.85))
    assert (exact["a"], exact["b"]) == (pytest.approx(1.164), pytest.approx(0.85))
    assert exact["levels"] == list(range(2, 10)) and exact["n"] == 32
    noisy = stiffness_frame(0.897, 1.04, np.random.default_rng(1).normal(0, 0.1, 40))
    fit = task3.power_fit(noisy)
    rows = noisy[noisy["level"].between(2, 9)]
    slope, intercept = np.polyfit(np.log(rows["level"]), np.log(rows["response"]), 1)
    assert fit["b"] == pytest.approx(slope, rel=1e-9) and fit["a"] == pytest.approx(math.exp(intercept), rel=1e-9)


def positioning_frame(lengths, devices=("fingertac",), cues=("P1",), objects=("cube_a",)) -> pd.DataFrame:
    rows, k = [], 0
    for device, cue, obj in itertools.product(devices, cues, objects):
        for i, length in enumerate(lengths):
            rows.append((k, f"P{i}", "t", device, cue, obj, 0.0, 1000.0, length, 10.0 + i, 6.0, 0.02, 0.01, 5.0))
            k += 1
    return pd.DataFrame(rows, columns=task4.COLUMNS)


def test_outlier_fences_are_tukeys_far_out_fences_on_logs():
    lengths = [4.1, 4.5, 3.9, 5.2, 4.8, 4.4, 30.0, 4.0]
    flags = task4.flag_outliers(positioning_frame(lengths))
    logs = np.log(lengths)
    q1, q3 = np.percentile(logs, [25, 75])
    expected = [v for v in lengths if not math.exp(q1 - 3 * (q3 - q1)) <= v <= math.exp(q3 + 3 * (q3 - q1))]
    assert expected == [30.0]
    assert flags["value"].tolist() == expected and flags["measure"].tolist() == ["trajectory_length"]
    assert flags["high"].iloc[0] == pytest.approx(math.exp(q3 + 3 * (q3 - q1)))


def test_device_comparison_is_a_paired_t_test():
    frame = pd.concat([positioning_frame([4.0, 5.0, 4.5, 6.0, 3.5], ("fingertac",)),
                       positioning_frame([6.0, 5.5, 7.5, 8.0, 5.0], ("ferrovibe",), ("3dof",))], ignore_index=True)
    frame["trial_id"] = range(len(frame))
    c = task4.compare_devices(frame, "fingertac", "ferrovibe")["trajectory_length"]
    d = np.array([4.0, 5.0, 4.5, 6.0, 3.5]) - np.array([6.0, 5.5, 7.5, 8.0, 5.0])
    t = d.mean() / (d.std(ddof=1) / math.sqrt(5))
    assert c["T"] == pytest.approx(t) and c["p"] == pytest.approx(2 * sps.t.sf(abs(t), 4))
    assert c["mean_diff"] == pytest.approx(d.mean()) and c["n_pairs"] == 5


def test_throughput_by_hand():
    geometry = {"cube_a": (np.array([0.0, 0.0, 0.0]), np.array([3.0, 4.0, 0.0]))}  # D = 5 along (0.6, 0.8, 0)
    frame = positioning_frame([4.0, 4.2, 4.4, 4.6])
    dx = np.array([0.02, -0.01, 0.03, -0.02])       # end-point deviation along the axis
    ends = np.array([3.0, 4.0, 0.0]) + dx[:, None] * np.array([0.6, 0.8, 0.0]) + np.array([0.0, 0.0, 0.01])
    mt = np.array([5.0, 6.0, 7.0, 8.0])
    endpoints = pd.DataFrame({"trial_id": frame["trial_id"], "pick_tick": 1000, "go_tick": 1000 + (mt + 2) * 1000,
                              "hold_s": 2.0, "end_x": ends[:, 0], "end_y": ends[:, 1], "end_z": ends[:, 2],
                              "n_samples": 201})
    tp = fitts.throughput(frame, endpoints, geometry)
    we = 4.133 * dx.std(ddof=1)
    ae = 5.0 + dx.mean()
    ide = math.log2(ae / we + 1)
    cond = tp["conditions"][0]
    assert cond["D"] == pytest.approx(5.0) and cond["We"] == pytest.approx(we) and cond["Ae"] == pytest.approx(ae)
    assert cond["MT"] == pytest.approx(mt.mean()) and cond["TP"] == pytest.approx(ide / mt.mean())
    assert tp["by_device"] == {"fingertac": pytest.approx(ide / mt.mean())}
