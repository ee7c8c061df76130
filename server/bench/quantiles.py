"""Percentiles of a bench's samples, with a confidence interval for the tail.

A p99 of ~100 samples is the sample's maximum: one bad sample decides it and the next run
differs by a factor. So every bench that prints a p99 from its own samples also prints a
distribution-free 95 % confidence interval for it: the order-statistic interval of the
quantile (scipy.stats.quantile_test(...).confidence_interval: the ranks come from the
binomial distribution of how many samples fall below the true quantile, so no distribution is
assumed). A bound the sample is too small for is None — e.g. with 100 samples there is no upper
bound for p99 (it would need a sample above the 100th), which says "take more samples".
"""

from __future__ import annotations

import math
from typing import Sequence

CONFIDENCE = 0.95


def percentile(values: Sequence[float], q: float) -> float | None:
    """The q-quantile of already sorted `values` (nearest rank), rounded to 3 decimals; None if empty."""
    return round(values[min(len(values) - 1, int(q * len(values)))], 3) if values else None


def percentile_ci(values: Sequence[float], q: float, confidence: float = CONFIDENCE) -> list[float | None] | None:
    """[low, high]: a distribution-free `confidence` interval for the q-quantile of the population
    `values` were drawn from, each rounded to 3 decimals; a bound the sample cannot give is None
    (too few samples in that tail). None for no samples."""
    if not values:
        return None
    from scipy.stats import quantile_test

    ci = quantile_test(values, q=0.0, p=q).confidence_interval(confidence)
    return [None if math.isnan(v) else round(float(v), 3) for v in (ci.low, ci.high)]


def tail(values: Sequence[float], prefix: str, unit: str, points=(("p50", 0.5), ("p99", 0.99), ("max", 1.0)),
         ci_for: tuple[str, ...] = ("p99",)) -> dict:
    """{prefix + name + unit: percentile} for each point of already sorted `values`, plus
    prefix + name + "_ci95" + unit for the points in `ci_for` (the tail's interval)."""
    out: dict = {}
    for name, q in points:
        out[f"{prefix}{name}{unit}"] = percentile(values, q)
        if name in ci_for:
            out[f"{prefix}{name}_ci95{unit}"] = percentile_ci(values, q)
    return out
