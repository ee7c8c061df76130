"""Repeated log lines are rate-limited with counts (server/log_repeats.py): the first at once, then
one summary per window; distinct lines are untouched."""

from __future__ import annotations

import io
import logging
import subprocess
import sys

import pytest

from server.log_repeats import RepeatFilter, RepeatLimiter, key

TRIP = "%s: the device's watchdog turned every actuator off (trip %d): the host was silent too long"


class Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def logger_with_filter(window_s: float = 10.0):
    out = io.StringIO()
    handler = logging.StreamHandler(out)
    handler.setFormatter(logging.Formatter("%(levelname)s %(message)s"))
    clock = Clock()
    f = RepeatFilter(handler, window_s, clock=clock)
    handler.addFilter(f)
    log = logging.getLogger(f"test.repeats.{id(out)}")
    log.propagate = False
    log.setLevel(logging.DEBUG)
    log.addHandler(handler)
    return log, out, clock, f


def test_numbers_do_not_make_a_line_new():
    assert key("a", 30, "trip 1 after 0.5 s") == key("a", 30, "trip 3826 after 12.25 s")
    assert key("a", 30, "x") != key("b", 30, "x") != key("a", 40, "x")


def test_a_33_minute_run_of_trips_writes_a_line_per_window_not_one_per_trip():
    log, out, clock, f = logger_with_filter(10.0)
    for trip in range(1, 4001):  # a trip every 0.5 s for 2000 s (about what the issue saw)
        clock.t = trip * 0.5
        log.warning(TRIP, "ferrovibe", trip)
    f.flush()
    lines = out.getvalue().splitlines()
    assert lines[0] == "WARNING " + TRIP % ("ferrovibe", 1)  # the first at once, unchanged
    assert len(lines) <= 2000 / 10 + 2, len(lines)
    summary = lines[1]
    assert "[repeated 19 times in the last 10 s]" in summary, summary  # trips 2..20 within the first window
    assert "(trip 20)" in summary  # the latest of them
    counted = sum(int(line.split("[repeated ")[1].split(" ")[0]) for line in lines[1:] if "[repeated" in line
                  and "once" not in line)
    counted += sum(1 for line in lines if "[repeated once" in line)
    assert counted + 1 == 4000  # every trip is written or counted


def test_distinct_lines_pass_and_a_quiet_line_is_written_at_once_again():
    log, out, clock, _ = logger_with_filter(10.0)
    log.info("device a connected")
    log.info("device b connected")  # another text: not a repeat
    clock.t = 1.0
    log.info("device a connected")  # a repeat: held back
    clock.t = 11.0
    log.info("something else")  # the window closed: its summary comes first
    clock.t = 30.0
    log.info("something else")  # its window closed without a repeat: forgotten, written at once
    lines = out.getvalue().splitlines()
    assert lines == ["INFO device a connected", "INFO device b connected",
                     "INFO device a connected [repeated once in the last 11 s]",
                     "INFO something else", "INFO something else"], lines


def test_the_limiter_rejects_a_window_of_zero():
    with pytest.raises(ValueError, match="window_s"):
        RepeatLimiter(0)


def test_the_server_process_installs_it_where_it_sets_up_logging():
    """`viestac …` (server/cli.py main) logs a repeated line once, and its count at exit."""
    code = ("import logging, sys\n"
            "from server import cli\n"
            "try:\n    cli.main(['--no-such-option'])\nexcept SystemExit:\n    pass\n"
            "for n in range(100):\n    logging.getLogger('viestac.devices').warning('trip %d', n)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    trips = [line for line in proc.stderr.splitlines() if "trip" in line]
    assert len(trips) == 2, proc.stderr[-2000:]
    assert trips[0].endswith("trip 0") and "trip 99 [repeated 99 times in the last" in trips[1]
