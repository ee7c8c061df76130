"""`viestac bench intervals`: its arithmetic on constructed timelines, and the shape of a short live
run. Timing goals are reported by the bench (docs/performance.md), never asserted here."""

from __future__ import annotations

import pytest

from devices.firmware_binding import Edge
from scenarios.registry import check_scenario_params, resolve
from scenarios.stimulus import plan_intervals
from server.bench.intervals_bench import (DURATIONS_MS, N_INTERVALS, PARAMS, draw_trials, interval_errors,
                                          run_intervals_bench, transitions)
from server.core.scenario import Trial


def vib(t_us: int, on: bool, channel: int = 0, cause: str = "command") -> Edge:
    return Edge(t_us, channel, on, 2 if on else 0, 100 if on else 0, 170 if on else 0, 0, 0, cause)


def test_transitions_pair_each_on_with_the_next_off_on_one_channel():
    edges = [vib(1_000, True), vib(1_000, True, channel=1), vib(1_500, True),  # a resend changes nothing
             vib(21_000, False), vib(21_000, False, channel=1), vib(61_000, True), vib(91_200, False),
             vib(200_000, True)]  # still on at the end: left out
    assert transitions(list(reversed(edges))) == [(1_000, 21_000), (61_000, 91_200)]
    assert transitions(edges, channel=1) == [(1_000, 21_000)]


def test_errors_against_the_plan():
    plan = [(40.0, 60.0), (100.0, 250.0), (290.0, 320.0)]
    # the device: first onset at 5 s; interval 2 starts 0.4 ms late and lasts 0.3 ms too short,
    # interval 3 is on time and 1.2 ms too long
    first = 5_000_000
    shown = [(first, first + 20_000), (first + 60_400, first + 60_400 + 149_700),
             (first + 250_000, first + 250_000 + 31_200)]
    onsets, durations = interval_errors(plan, shown)
    assert onsets == pytest.approx([0.4, 0.0])
    assert durations == pytest.approx([0.0, -0.3, 1.2])
    with pytest.raises(ValueError, match="2 intervals shown for 3 planned"):
        interval_errors(plan, shown[:2])


def test_the_drawn_trials_are_seeded_and_planned_by_the_scenario():
    trials = draw_trials(10, seed=3)
    assert trials == draw_trials(10, seed=3) != draw_trials(10, seed=4)
    assert len(trials) == 3 and all(t["n_intervals"] == N_INTERVALS for t in trials)
    spec = resolve("stimulus")
    params = check_scenario_params(spec, PARAMS)
    plan = plan_intervals(params, Trial.parse(spec.factory.TRIAL_PARAMS, "main", trials[0]).params)
    lengths = [i.off_ms - i.on_ms for i in plan]
    assert lengths == [trials[0][f"level_{k}"] for k in range(1, N_INTERVALS + 1)]
    assert all(DURATIONS_MS[0] <= n <= DURATIONS_MS[1] for n in lengths)
    assert plan[0].on_ms == PARAMS["lead_ms"] and plan[1].on_ms == plan[0].off_ms + PARAMS["isi_ms"]


def test_a_short_live_run_measures_every_interval():
    result = run_intervals_bench(intervals=8)
    assert result["trials"] == 2 and result["unmatched_trials"] == 0
    assert result["intervals"] == 8 and result["onsets_measured"] == 6
    for key in ("onset_error_p99_ms", "duration_error_p99_ms", "read_duration_error_p50_ms", "period_p99_us"):
        assert result[key] is not None
    assert result["pass"] is not True  # too few intervals to pass the acceptance (a miss still shows)
