"""Clocks: the loop's only source of time (rclpy-style: time is a dependency).

MonotonicClock is real time (CLOCK_MONOTONIC, shared by every process on the machine, so the
hub and the loop process can compare stamps). VirtualClock is stepped by the caller: sleeping
until a deadline just jumps there, so a whole study runs as fast as the CPU allows and replays
identically. Inside the loop process only this module calls `time`.
"""

from __future__ import annotations

import time
from typing import Protocol


class Clock(Protocol):
    def now_ns(self) -> int: ...

    def sleep_until(self, deadline_ns: int) -> None: ...


class MonotonicClock:
    def now_ns(self) -> int:
        return time.monotonic_ns()

    def sleep_until(self, deadline_ns: int) -> None:
        # Plain sleep to an absolute deadline, no spinning: a real-time process that spins can
        # starve the lower-priority process it waits for (docs/architecture.md, the loop's rules).
        remaining = deadline_ns - time.monotonic_ns()
        if remaining > 0:
            time.sleep(remaining / 1e9)


class VirtualClock:
    """A clock that only moves when told to (tests, simulated studies, replays)."""

    def __init__(self, start_ns: int = 0):
        self._now = start_ns

    def now_ns(self) -> int:
        return self._now

    def sleep_until(self, deadline_ns: int) -> None:
        if deadline_ns > self._now:
            self._now = deadline_ns

    def advance(self, dt_ns: int) -> None:
        if dt_ns < 0:
            raise ValueError("a clock does not go backwards")
        self._now += dt_ns
