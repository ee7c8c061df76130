"""d′ and criterion, information transfer, the synthetic observer, QUEST+'s criterion."""

import math

import numpy as np
import pytest
from scipy.special import ndtr

from server.psychophysics.functions import FAMILIES
from server.psychophysics.information import from_distribution, information_transfer
from server.psychophysics.observer import PsychometricObserver, ThresholdCurve, WeberObserver
from server.psychophysics.questplus import QuestPlus, QuestPlusGrid
from server.psychophysics.sdt import same_different, yes_no


def test_yes_no_d_prime_and_criterion():
    h, f = float(ndtr(1.0)), float(ndtr(-1.0))  # z(H) = 1, z(F) = −1
    s = yes_no(h * 1e6, 1e6, f * 1e6, 1e6, correction="none")
    assert s.d_prime == pytest.approx(2.0, abs=1e-9) and s.criterion == pytest.approx(0.0, abs=1e-9)
    biased = yes_no(float(ndtr(1.5)) * 1e6, 1e6, float(ndtr(-0.5)) * 1e6, 1e6, correction="none")
    assert biased.d_prime == pytest.approx(2.0, abs=1e-9) and biased.criterion == pytest.approx(-0.5, abs=1e-9)


def test_perfect_rates_stay_finite_with_the_loglinear_correction():
    s = yes_no(20, 20, 0, 20)
    assert s.hit_rate == pytest.approx(20.5 / 21) and math.isfinite(s.d_prime)
    with pytest.raises(ValueError, match="loglinear"):
        yes_no(20, 20, 0, 20, correction="none")


def test_same_different_differencing_model_recovers_d_prime_and_k():
    d, k = 2.0, 1.5
    f = 2 * float(ndtr(-k / math.sqrt(2)))
    h = float(ndtr((d - k) / math.sqrt(2)) + ndtr((-d - k) / math.sqrt(2)))
    s = same_different(h * 1e6, 1e6, f * 1e6, 1e6, correction="none")
    assert s.d_prime == pytest.approx(d, abs=1e-6) and s.criterion == pytest.approx(k, abs=1e-6)
    assert same_different(10, 40, 12, 40).d_prime == 0.0  # H ≤ F


@pytest.mark.parametrize("k", [2, 3, 5, 8])
def test_information_transfer_is_exact_on_constructed_matrices(k):
    assert information_transfer(np.eye(k) * 9).bits == pytest.approx(math.log2(k), abs=1e-12)
    perm = np.eye(k)[np.random.default_rng(k).permutation(k)] * 4
    assert information_transfer(perm).bits == pytest.approx(math.log2(k), abs=1e-12)
    assert information_transfer(np.ones((k, k)) * 5).bits == 0.0
    assert information_transfer(np.tile([1, 2, 3], (k, 1))).bits == 0.0  # every row alike


def test_information_transfer_refuses_bad_matrices():
    for bad in ([[1, -1], [0, 1]], [[0, 0], [0, 0]], [1, 2, 3]):
        with pytest.raises(ValueError):
            information_transfer(bad)


def test_the_channel_information_of_a_noiseless_channel():
    assert from_distribution(np.eye(4)) == pytest.approx(2.0)


def test_observer_answers_are_reproducible_and_follow_p():
    obs = PsychometricObserver(5.0, 2.0, 0.5, 0.04, "logistic")
    assert obs.probability(5.0) == pytest.approx(0.5 + 0.46 * 0.5)
    a = obs.answer(np.full(20000, 5.0), np.random.default_rng(1))
    assert np.array_equal(a, obs.answer(np.full(20000, 5.0), np.random.default_rng(1)))
    assert a.mean() == pytest.approx(0.73, abs=0.01)
    assert obs.level_at(0.73) == pytest.approx(5.0)


def test_threshold_curve_is_a_u_over_frequency_and_weber_scales():
    curve = ThresholdCurve()
    thresholds = curve.threshold([31.25, 62.5, 125, 250, 500, 1000])
    assert np.argmin(thresholds) == 3 and thresholds[0] > thresholds[2] and thresholds[-1] > thresholds[-2]
    assert curve.observer_at(500).threshold == pytest.approx(curve.minimum + curve.curvature)
    weber = WeberObserver(0.1)
    assert weber.observer_at(50.0).threshold == pytest.approx(5.0)
    with pytest.raises(ValueError):
        weber.observer_at(0.0)


def test_the_expected_entropy_equals_its_definition():
    """The table trick (one product, Σ π log π dropped) ranks stimuli as the textbook formula."""
    fam = FAMILIES["logistic"]
    grid = QuestPlusGrid.from_model(
        lambda s, t: fam.probability(s["level"], t["threshold"], t["slope"], 0.5, 0.02),
        {"level": np.linspace(-2, 2, 9)}, {"threshold": np.linspace(-1, 1, 7), "slope": [0.5, 1, 2]})
    q = QuestPlus(grid, 10)
    q.update(True)
    q.update(False)
    pi = q.posterior
    brute = []
    for x in range(9):
        h = 0.0
        for r in range(2):
            joint = grid.likelihood[r, x] * pi
            z = joint.sum()
            post = joint / z
            h += z * -(post[post > 0] * np.log(post[post > 0])).sum()
        brute.append(h)
    const = (pi * np.log(pi)).sum()
    assert np.allclose(q.expected_entropy() - const, brute, atol=1e-12)


def test_quest_plus_with_two_stimulus_dimensions_and_a_prior():
    """Threshold over frequency (a U): QUEST+ chooses level and frequency and finds the curve."""
    true = ThresholdCurve(minimum=-20, best=250, curvature=6, slope=0.5, guess=0.5, lapse=0.0)

    def model(s, t):
        threshold = t["minimum"] + t["curvature"] * np.log2(s["frequency"] / 250.0) ** 2
        return FAMILIES["gumbel"].probability(s["level"], threshold, 0.5, 0.5, 0.0)

    params = {"minimum": np.linspace(-30, -10, 21), "curvature": np.linspace(0, 12, 13)}
    stimuli = {"level": np.linspace(-35, 10, 46), "frequency": [62.5, 125, 250, 500, 1000]}
    grid = QuestPlusGrid.from_model(model, stimuli, params)
    rng = np.random.default_rng(8)
    q = QuestPlus(grid, 80, "mean")
    frequencies = set()
    while not q.finished:
        s = q.stimulus
        frequencies.add(s["frequency"])
        q.update(bool(rng.random() < true.probability(s["level"], s["frequency"])))
    est = q.estimates()
    assert len(frequencies) > 1
    assert est["minimum"] == pytest.approx(-20, abs=2.5) and est["curvature"] == pytest.approx(6, abs=2.5)
    # a prior moves the estimate before any answer
    prior = np.exp(-0.5 * ((grid.params["minimum"] + 12) / 2.0) ** 2)
    assert QuestPlus(QuestPlusGrid(grid.likelihood, grid.stimuli, grid.params, prior), 5).estimates()["minimum"] \
        == pytest.approx(-12, abs=1.0)
    assert QuestPlus(grid, 5, "mode").estimates()["minimum"] in grid.params["minimum"]
