"""Deadline scheduling for the fixed-rate loop.

Deadlines advance by exactly one period (`next += period`), so lateness in one tick does not
shift every later tick (no drift; loop-rate-limiters schedules from wake-up time and drifts).
If the loop falls more than `max_lag_periods` behind (a stall: swap, a debugger, a suspended
VM), it resynchronises to "now" instead of bursting through the missed ticks, and counts it.
"""

from __future__ import annotations

from server.loop.clock import Clock


class DeadlineScheduler:
    def __init__(self, clock: Clock, period_ns: int, max_lag_periods: int = 50):
        if period_ns <= 0:
            raise ValueError("period_ns must be positive")
        self.clock = clock
        self.period_ns = period_ns
        self.max_lag_ns = max_lag_periods * period_ns
        self.resyncs = 0
        self._deadline = clock.now_ns() + period_ns
        self._last_start: int | None = None

    def wait_next(self) -> tuple[int, int]:
        """Sleep until the next deadline; return (tick start ns, period since last start ns)."""
        self.clock.sleep_until(self._deadline)
        start = self.clock.now_ns()
        if start - self._deadline > self.max_lag_ns:
            self.resyncs += 1
            self._deadline = start
        self._deadline += self.period_ns
        period = self.period_ns if self._last_start is None else start - self._last_start
        self._last_start = start
        return start, period
