"""Psychometric fits: equal to statsmodels' binomial GLM where the models coincide (yes/no, no
lapse), recover the generating function, keep the lapse within its bound; the bootstrap."""

import numpy as np
import pytest
import statsmodels.api as sm

from server.psychophysics.fit import bootstrap, fit, fit_many
from server.psychophysics.functions import FAMILIES
from server.psychophysics.observer import PsychometricObserver

LINKS = {"logistic": sm.families.links.Logit(), "normal": sm.families.links.Probit()}


@pytest.mark.parametrize("family", ["logistic", "normal"])
@pytest.mark.parametrize("seed", range(5))
def test_yes_no_without_lapse_equals_the_binomial_glm(family, seed):
    rng = np.random.default_rng(seed)
    levels = np.sort(rng.uniform(-3, 3, 8))
    n = rng.integers(10, 60, 8)
    observer = PsychometricObserver(rng.uniform(-1, 1), rng.uniform(0.5, 1.2), 0.0, 0.0, family)  # no separation
    k = rng.binomial(n, observer.probability(levels))
    ours = fit(levels, n, k, family, guess=0.0, lapse_max=0.0)
    glm = sm.GLM(np.column_stack([k, n - k]), sm.add_constant(levels),
                 family=sm.families.Binomial(link=LINKS[family])).fit(tol=1e-14)
    b0, b1 = glm.params
    assert ours.converged
    assert ours.slope == pytest.approx(b1, abs=1e-6)
    assert ours.threshold == pytest.approx(-b0 / b1, abs=1e-6)
    assert ours.deviance == pytest.approx(glm.deviance, abs=1e-6)
    assert ours.lapse == 0.0


@pytest.mark.parametrize("family", ["logistic", "normal", "gumbel", "weibull"])
def test_a_large_data_set_recovers_the_generating_function(family):
    rng = np.random.default_rng(1)
    true = PsychometricObserver(2.0, 3.0 if family == "weibull" else 1.5, 0.5, 0.02, family)
    levels = np.geomspace(0.5, 6.0, 9) if family == "weibull" else np.linspace(-1, 5, 9)
    n = np.full(9, 4000)
    k = rng.binomial(n, true.probability(levels))
    result = fit(levels, n, k, family, guess=0.5, lapse_max=0.06)
    assert result.threshold == pytest.approx(true.threshold, rel=0.03)
    assert result.slope == pytest.approx(true.slope, rel=0.1)
    assert 0.0 <= result.lapse <= 0.06 and result.lapse == pytest.approx(0.02, abs=0.01)


def test_the_lapse_stays_within_its_bound():
    levels = np.linspace(0, 10, 6)
    n = np.full(6, 50)
    k = np.array([25, 26, 35, 40, 41, 40])  # tops out at 80 %: a lapse of 20 % would fit best
    result = fit(levels, n, k, "logistic", guess=0.5, lapse_max=0.06)
    assert 0.0 < result.lapse <= 0.06


def test_separated_data_stop_at_the_slope_bound():
    result = fit([0, 1, 2, 3], [20] * 4, [0, 0, 20, 20], "logistic", 0.0, 0.0)
    assert np.isfinite(result.slope) and 1.0 < result.threshold < 2.0


def test_many_data_sets_fit_at_once_as_one_by_one():
    rng = np.random.default_rng(3)
    levels, n = np.linspace(-2, 2, 6), np.full(6, 30)
    k = rng.binomial(n, FAMILIES["normal"].probability(levels, 0.2, 1.2, 0.5, 0.01), size=(5, 6))
    batch = fit_many(levels, n, k, "normal", 0.5, 0.05)
    for i in range(5):
        one = fit(levels, n, k[i], "normal", 0.5, 0.05)
        assert batch["threshold"][i] == pytest.approx(one.threshold, abs=1e-9)


def test_bootstrap_interval_deviance_p_and_reproducibility():
    true = PsychometricObserver(1.0, 3.0, 0.5, 0.01, "weibull")
    levels, n = np.geomspace(0.5, 2, 7), np.full(7, 40)
    k = np.random.default_rng(4).binomial(n, true.probability(levels))
    result = fit(levels, n, k, "weibull", 0.5, 0.06)
    a = bootstrap(result, levels, n, np.random.default_rng(5), samples=300)
    b = bootstrap(result, levels, n, np.random.default_rng(5), samples=300)
    assert a.threshold_ci == b.threshold_ci
    assert a.threshold_ci[0] < result.threshold < a.threshold_ci[1]
    assert a.slope_ci[0] < result.slope < a.slope_ci[1]
    assert 0.0 <= a.deviance_p <= 1.0


def test_bad_data_are_refused_by_name():
    with pytest.raises(ValueError, match="n > 0"):
        fit([1, 2], [0, 5], [0, 1])
    with pytest.raises(ValueError, match="two distinct"):
        fit([1, 1], [5, 5], [1, 2])
    with pytest.raises(ValueError, match="levels > 0"):
        fit([0, 1], [5, 5], [1, 2], "weibull", 0.5)
