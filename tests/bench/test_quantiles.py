"""The benches' percentiles and the confidence interval of their tail (issue 23): distribution-free
order-statistic intervals, no upper bound for a p99 of 100 samples, and the stated coverage."""

import math

import numpy as np
from scipy.stats import binom

from server.bench.quantiles import percentile, percentile_ci, tail


def order_statistic_interval(values, q, confidence=0.95):
    """The same interval computed another way: the ranks l < u with P(l <= B < u) >= confidence for
    B ~ Binomial(n, q), the number of samples below the true quantile."""
    x = sorted(values)
    n = len(x)
    alpha = 1 - confidence
    lo, u = int(binom.ppf(alpha / 2, n, q)), int(binom.ppf(1 - alpha / 2, n, q)) + 1
    return (x[lo - 1] if lo >= 1 else None), (x[u - 1] if u <= n else None)


def test_percentile_is_the_nearest_rank():
    values = sorted(float(v) for v in range(1, 101))
    assert percentile(values, 0.5) == 51.0 and percentile(values, 0.99) == 100.0 and percentile(values, 1.0) == 100.0
    assert percentile([], 0.99) is None and percentile_ci([], 0.99) is None


def test_a_p99_of_100_samples_has_no_upper_bound_and_1000_samples_give_one():
    rng = np.random.default_rng(3)
    small = sorted(rng.exponential(size=100))
    low, high = percentile_ci(small, 0.99)
    assert high is None and low is not None and low <= percentile(small, 0.99), "the maximum is not a p99"
    large = sorted(rng.exponential(size=1000))
    low, high = percentile_ci(large, 0.99)
    assert low < percentile(large, 0.99) < high <= max(large)
    ref_low, ref_high = order_statistic_interval(large, 0.99)
    assert math.isclose(low, ref_low, abs_tol=5e-4) and math.isclose(high, ref_high, abs_tol=5e-4)


def test_the_interval_covers_the_true_quantile_as_often_as_stated():
    rng = np.random.default_rng(11)
    truth = -math.log(1 - 0.99)  # exponential(1)'s p99
    hits = 0
    for _ in range(300):
        low, high = percentile_ci(sorted(rng.exponential(size=1000)), 0.99)
        hits += low <= truth <= high
    assert 0.92 <= hits / 300 <= 0.995, hits


def test_tail_names_the_points_and_the_p99_interval():
    values = sorted(float(v) for v in range(1000))
    out = tail(values, "read_", "_ms")
    assert list(out) == ["read_p50_ms", "read_p99_ms", "read_p99_ci95_ms", "read_max_ms"]
    assert out["read_p99_ci95_ms"][0] <= out["read_p99_ms"] <= out["read_p99_ci95_ms"][1]
