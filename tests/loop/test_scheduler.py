"""Deadline scheduling on a virtual clock: no drift, overrun accounting, resync after stalls."""

from server.loop.clock import VirtualClock
from server.loop.scheduler import DeadlineScheduler

MS = 1_000_000


def test_deadlines_do_not_drift_when_ticks_run_late():
    clock = VirtualClock()
    sched = DeadlineScheduler(clock, MS)
    starts = []
    for i in range(1000):
        start, _ = sched.wait_next()
        starts.append(start)
        clock.advance(300_000 if i % 7 else 1_400_000)  # work time; sometimes longer than a period
    # Every tick starts on the 1 ms grid or late by at most the overrun; tick 1000 is at 1000 ms,
    # not 1000 ms plus the accumulated lateness.
    assert starts[-1] <= 1000 * MS + 1_400_000
    assert starts[999] - starts[0] <= 999 * MS + 400_000
    assert sched.resyncs == 0


def test_period_reports_actual_spacing():
    clock = VirtualClock()
    sched = DeadlineScheduler(clock, MS)
    sched.wait_next()
    clock.advance(2_500_000)  # an overrun: the next period is long
    _, period = sched.wait_next()
    assert period == 2_500_000
    start, period = sched.wait_next()
    assert period == 0  # the late tick of the 3 ms slot runs at once (catch up, do not skip)
    start, period = sched.wait_next()
    assert start == 4 * MS and period == 500_000  # back on the 1 ms grid


def test_stall_resyncs_instead_of_bursting():
    clock = VirtualClock()
    sched = DeadlineScheduler(clock, MS, max_lag_periods=10)
    sched.wait_next()
    clock.advance(500 * MS)  # a half-second stall
    start, _ = sched.wait_next()
    assert sched.resyncs == 1
    nxt, period = sched.wait_next()
    assert nxt - start == MS and period == MS  # back on a fresh grid, no burst of 500 ticks
