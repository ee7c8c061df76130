"""The default models resemble the thesis's results (chapter 5), checked through the public API
(SyntheticParticipant.answer / produce_level) with independent statistics written here:
numpy.polyfit for the power laws, scipy's Kendall tau-b, plain means for the rest."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import kendalltau

from server.synthetic import ObserverModels, SyntheticParticipant
from tests.synthetic.conftest import PERIODS_US

N = 13                       # the thesis's participants (§5.1)
LEVELS = np.arange(1, 11)
FIT = slice(1, 9)            # levels 2..9, as the thesis fits (§5.4.3)
ANGLES = (-90.0, -70.0, -50.0, -30.0, -10.0, 10.0, 30.0, 50.0, 70.0, 90.0)


def stiffness_study(seed: int, question, models=None) -> tuple[np.ndarray, np.ndarray]:
    """(estimates, productions) of 13 participants × levels 1..10."""
    est, prod = np.zeros((N, 10)), np.zeros((N, 10))
    for i in range(N):
        p = SyntheticParticipant(seed, i, models)
        for k, level in enumerate(LEVELS):
            trial = {"seq": 30 + k, "scenario": "stiffness-v1", "params": {"mode": "estimation", "level": int(level)}}
            est[i, k] = p.answer(trial, question)
            prod[i, k] = p.produce_level(int(level), seq=40 + k)
    return est, prod


def power_fit(answers: np.ndarray) -> tuple[float, float]:
    """(a, b) of log(mean answer) = log a + b·log S on levels 2..9 (ordinary least squares)."""
    b, log_a = np.polyfit(np.log(LEVELS[FIT]), np.log(answers[:, FIT].mean(axis=0)), 1)
    return float(np.exp(log_a)), float(b)


def test_power_law_exponents_are_recovered_from_13_participants(questions):
    """Default (modest) noise σ = 0.05: over 100 simulated studies of 13 participants the fitted
    exponents average within ±0.01 of 0.85 and 1.04, and a single study recovers them within
    ±0.05 in at least 85 % of the studies (measured: 93 % and 92 %; whole-number answers limit
    a 13-participant fit to an SD of about 0.027 / 0.030)."""
    q = questions["answer_level"]
    fits = np.array([[*power_fit(e), *power_fit(p)] for e, p in (stiffness_study(s, q) for s in range(100))])
    a_est, b_est, a_prod, b_prod = fits.T
    assert abs(b_est.mean() - 0.85) < 0.01 and abs(b_prod.mean() - 1.04) < 0.01
    assert abs(a_est.mean() - 1.164) < 0.03 and abs(a_prod.mean() - 0.897) < 0.03
    assert np.mean(np.abs(b_est - 0.85) <= 0.05) >= 0.85
    assert np.mean(np.abs(b_prod - 1.04) <= 0.05) >= 0.85
    # response regression: estimation compresses (b < 1), production expands (b > 1)
    assert b_est.mean() < 1.0 < b_prod.mean()


def test_other_exponents_are_recovered_too(questions):
    models = ObserverModels().with_overrides({"estimation.b": 0.7, "estimation.a": 1.5, "production.b": 1.2,
                                              "production.a": 0.6})
    fits = np.array([[power_fit(e)[1], power_fit(p)[1]]
                     for e, p in (stiffness_study(s, questions["answer_level"], models) for s in range(30))])
    assert abs(fits[:, 0].mean() - 0.7) < 0.015 and abs(fits[:, 1].mean() - 1.2) < 0.015


def identification_tau(seed: int, question, models=None) -> float:
    actual, named = [], []
    for i in range(N):
        p = SyntheticParticipant(seed, i, models)
        for k, period in enumerate(PERIODS_US):
            actual.append(1e6 / period)
            named.append(p.answer({"seq": 20 + k, "scenario": "texture-v1", "params": {"period_us": period}}, question))
    return float(kendalltau(actual, named).statistic)  # scipy's default variant: tau-b


def test_noiseless_identifier_has_tau_one(questions):
    perfect = ObserverModels().with_overrides({"identification.weber": 0})
    assert [identification_tau(s, questions["answer_hz"], perfect) for s in range(5)] == [1.0] * 5


def test_tau_falls_as_confusion_grows(questions):
    """Mean tau-b over 40 studies for growing w (measured ≈ 1.0, 0.92, 0.79, 0.68, 0.54, 0.38)."""
    means = []
    for w in (0.0, 0.1, 0.2, 0.3, 0.45, 0.7):
        models = ObserverModels().with_overrides({"identification.weber": w})
        means.append(np.mean([identification_tau(s, questions["answer_hz"], models) for s in range(40)]))
    assert means[0] == 1.0
    assert all(a > b for a, b in zip(means, means[1:])), means


def test_default_tau_is_near_the_thesis(questions):
    """Thesis §5.3.3: tau = 0.67 for 13 participants × 5 textures. Mean over 200 simulated
    studies within ±0.03 (measured 0.676; a single study varies with SD ≈ 0.05)."""
    taus = [identification_tau(s, questions["answer_hz"]) for s in range(200)]
    assert abs(np.mean(taus) - 0.67) <= 0.03


def angle_deviations(seeds, question, models=None) -> np.ndarray:
    """|answer − angle| of 13 participants per study, stacked: rows participants, columns ANGLES."""
    rows = []
    for seed in seeds:
        for i in range(N):
            p = SyntheticParticipant(seed, i, models)
            rows.append([abs(p.answer({"seq": 4 + k, "scenario": "contact-angle-v1", "params": {"angle_deg": a}},
                                      question) - a) for k, a in enumerate(ANGLES)])
    return np.array(rows)


def test_angle_error_is_u_shaped(questions):
    """Mean absolute deviation per angle over 30 studies × 13 participants: larger at ±70/±90 than
    at ±10/±30 (measured ≈ 8° at ±10, 9.5° at ±30, 11.5° at ±50, 13° at ±70 and ±90), with the
    fan-out the thesis saw (a larger spread at the ends)."""
    dev = angle_deviations(range(30), questions["answer_deg"])
    mad = dict(zip(ANGLES, dev.mean(axis=0)))
    spread = dict(zip(ANGLES, dev.std(axis=0)))
    middle = [mad[a] for a in (-30.0, -10.0, 10.0, 30.0)]
    for end in (-90.0, -70.0, 70.0, 90.0):
        assert mad[end] > max(middle) + 2.0, mad
        assert spread[end] > max(spread[a] for a in (-10.0, 10.0)), spread
    assert 5.0 < mad[10.0] < 11.0 and 11.0 < mad[90.0] < 18.0, mad
    # a quadratic fit of deviation on angle opens upwards (the thesis's red curve, Figure 5.2)
    curvature = np.polyfit(np.tile(ANGLES, len(dev)), dev.ravel(), 2)[0]
    assert curvature > 0


def test_texture_ratings_order_like_the_thesis(questions):
    """Mean "second vs first" per second texture (first = 250 Hz), 40 studies × 13: the
    roughest is rated rougher (> 5), the smoothest smoother (< 2), 250 vs 250 mostly "same"."""
    q = questions["rating"]
    ratings = {period: [] for period in PERIODS_US}
    for seed in range(40):
        for i in range(N):
            p = SyntheticParticipant(seed, i)
            for k, period in enumerate(PERIODS_US):
                trial = {"seq": 15 + k, "scenario": "texture-v1",
                         "params": {"period_us": 4000.0, "second_period_us": period}}
                ratings[period].append(p.answer(trial, q))
    mean = {period: np.mean(r) for period, r in ratings.items()}
    assert mean[6000.0] > 5.0 and mean[2000.0] < 2.0
    assert mean[2000.0] < mean[3000.0] < mean[4000.0] < mean[5000.0] < mean[6000.0]
    assert abs(mean[4000.0] - 4.0) < 0.15 and np.mean(np.array(ratings[4000.0]) == 4) > 0.7


def test_questionnaire_choices_resemble_the_thesis(thesis, questions):
    """84.6 % preferred continuous vibration; best pattern 5 / 6 / 1 / 1 of 13 (§5.5.3):
    proportions over 2000 participants within ±0.03."""
    modes, patterns = [], []
    for i in range(2000):
        p = SyntheticParticipant(11, i)
        trial = {"seq": 52, "scenario": "positioning-v1", "params": {}}
        modes.append(p.answer(trial, questions["better_mode"]))
        patterns.append(p.answer(dict(trial, seq=64), questions["best_pattern"]))
    assert abs(modes.count("continuous vibration at target") / 2000 - 0.846) < 0.03
    for choice, count in (("P1", 5), ("P2", 6), ("P3", 1), ("all felt the same", 1)):
        assert abs(patterns.count(choice) / 2000 - count / 13) < 0.03, (choice, patterns.count(choice))


def test_helpfulness_ratings_resemble_the_thesis(questions):
    """Per-pattern means near §5.5.3's 5.26 / 5.26 / 5.36 (FerroVibe 5.14), SD near 1.1."""
    q = questions["helpfulness"]
    by_cue = {cue: [] for cue in ("P1", "P2", "P3", "3dof")}
    for i in range(1500):
        p = SyntheticParticipant(5, i)
        for k, cue in enumerate(by_cue):
            by_cue[cue].append(p.answer({"seq": 55 + k, "scenario": "positioning-v1",
                                         "params": {"object": "cube_a", "cue": cue}}, q))
    for cue, target in (("P1", 5.26), ("P2", 5.26), ("P3", 5.36), ("3dof", 5.14)):
        assert abs(np.mean(by_cue[cue]) - target) < 0.12, (cue, np.mean(by_cue[cue]))
        assert 0.9 < np.std(by_cue[cue]) < 1.35


@pytest.mark.parametrize("w", [0.0, 0.3])
def test_identification_answers_are_declared_choices(questions, w):
    q = questions["answer_hz"]
    models = ObserverModels().with_overrides({"identification.weber": w})
    p = SyntheticParticipant(3, 0, models)
    for k, period in enumerate(PERIODS_US):
        value = p.answer({"seq": k, "scenario": "texture-v1", "params": {"period_us": period}}, q)
        assert value in q.choices and isinstance(value, float)
        if w == 0.0:
            assert value == round(1e6 / period, 2)
