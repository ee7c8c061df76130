"""Loop timing statistics, computed on the hub side so the 1 kHz loop only appends numbers.

The loop ships raw timing samples with each state record (server/core/records.py
TIMING_SAMPLE: period, cost, and whether the tick published a state record). Here they feed a
rolling window (the last `window_s` seconds, for /api/health and state frames) and cumulative
histograms with 1 µs bins since the last reset (for `viestac bench loop`, whose runs are longer
than the window), the costs also for the publishing ticks alone and for the others. An overrun is
a period over 1.5 ms (1.5 periods at 1 kHz).
"""

from __future__ import annotations

import numpy as np

from server.core.records import TIMING_SAMPLE

OVERRUN_US = 1500
_BINS = 100_000  # 1 µs bins up to 100 ms; longer periods land in the last bin (max is exact)


class LoopTelemetry:
    def __init__(self, window_s: float = 10.0, tick_hz: int = 1000):
        self._size = max(1, int(window_s * tick_hz))
        self._period = np.zeros(self._size, dtype=np.int64)
        self._cost = np.zeros(self._size, dtype=np.int64)
        self._count = 0  # samples written into the ring in total
        self.rt = False
        self.resyncs = 0
        self.reset_cumulative()

    def reset_cumulative(self) -> None:
        self._hist_period = np.zeros(_BINS, dtype=np.int64)
        self._hist_cost = np.zeros(_BINS, dtype=np.int64)
        self._hist_cost_published = np.zeros(_BINS, dtype=np.int64)  # the ticks that published a state record
        self._max_period_us = 0.0
        self._max_cost_us = 0.0
        self._ticks_since_reset = 0

    def add(self, samples: bytes) -> int:
        """Take a state record's timing samples; returns how many of its periods were overruns."""
        flat = np.frombuffer(samples, dtype=np.int64)
        width = len(TIMING_SAMPLE)
        if flat.size < width:
            return 0
        rows = flat[:flat.size - flat.size % width].reshape(-1, width)
        periods_ns, costs_ns = rows[:, 0], rows[:, 1]
        periods_us = periods_ns / 1000.0
        costs_us = costs_ns / 1000.0
        n = periods_us.size
        idx = (self._count + np.arange(n)) % self._size
        self._period[idx] = periods_ns
        self._cost[idx] = costs_ns
        self._count += n
        self._hist_period += np.bincount(np.minimum(periods_us.astype(np.int64), _BINS - 1), minlength=_BINS)
        cost_bins = np.minimum(costs_us.astype(np.int64), _BINS - 1)
        self._hist_cost += np.bincount(cost_bins, minlength=_BINS)
        self._hist_cost_published += np.bincount(cost_bins[rows[:, 2] != 0], minlength=_BINS)
        self._max_period_us = max(self._max_period_us, float(periods_us.max()))
        self._max_cost_us = max(self._max_cost_us, float(costs_us.max()))
        self._ticks_since_reset += n
        return int(np.count_nonzero(periods_ns > OVERRUN_US * 1000))

    @property
    def ticks(self) -> int:
        return self._count

    def window(self) -> dict:
        """Rolling-window summary (the shape carried in state frames and /api/health)."""
        n = min(self._count, self._size)
        if n == 0:
            return {"period_p50_us": 0.0, "period_p99_us": 0.0, "period_max_us": 0.0, "overruns": 0,
                    "tick_cost_p99_us": 0.0, "ticks": 0, "rt": self.rt}
        periods = self._period[:n] / 1000.0
        costs = self._cost[:n] / 1000.0
        p50, p99 = np.percentile(periods, [50, 99])
        return {"period_p50_us": round(float(p50), 1), "period_p99_us": round(float(p99), 1),
                "period_max_us": round(float(periods.max()), 1),
                "overruns": int(np.count_nonzero(periods > OVERRUN_US)),
                "tick_cost_p99_us": round(float(np.percentile(costs, 99)), 1), "ticks": self._count, "rt": self.rt}

    def cumulative(self) -> dict:
        """Exact-to-1-µs percentiles of everything since the last reset."""
        def pct(hist: np.ndarray, q: float) -> float:
            total = int(hist.sum())
            if total == 0:
                return 0.0
            return float(np.searchsorted(np.cumsum(hist), q * total, side="left"))

        published, quiet = self._hist_cost_published, self._hist_cost - self._hist_cost_published
        return {"ticks": self._ticks_since_reset,
                "period_p50_us": pct(self._hist_period, 0.50), "period_p99_us": pct(self._hist_period, 0.99),
                "period_p999_us": pct(self._hist_period, 0.999), "period_max_us": round(self._max_period_us, 1),
                "overruns": int(self._hist_period[OVERRUN_US:].sum()),
                "tick_cost_p50_us": pct(self._hist_cost, 0.50), "tick_cost_p99_us": pct(self._hist_cost, 0.99),
                "tick_cost_max_us": round(self._max_cost_us, 1),
                "published_ticks": int(published.sum()),
                "tick_cost_published_p50_us": pct(published, 0.50), "tick_cost_published_p99_us": pct(published, 0.99),
                "tick_cost_quiet_p50_us": pct(quiet, 0.50), "tick_cost_quiet_p99_us": pct(quiet, 0.99),
                "rt": self.rt, "resyncs": self.resyncs}
