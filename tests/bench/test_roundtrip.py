"""`viestac bench roundtrip`: the participant's paths against the real loop core, matching samples
to the frames that show them, the summary, and the shape of a short live run. Timing goals are
reported by the bench (docs/performance.md), never asserted here."""

from __future__ import annotations

import math

import pytest

from scenarios.contact_angle import ContactAngle
from server.bench.roundtrip import BAND_MS, TAG_PERIOD, match_samples, sample_position, summarize
from server.bench.roundtrip_bench import phase_plan, run_roundtrip_bench
from server.loop.tick import Loop
from server.loop.simulation import Simulation
from server.ipc.records import TrackerSample
from tests.ipc import state_map

MS = 1_000_000  # ns


def _drive(where: str, first: int, count: int, ticks_per_sample: int = 17):
    """Feed samples first..first+count-1 of a path into the real loop core, one every
    `ticks_per_sample` ticks; yield (k, position, the state record of the tick that applied it
    or None, that tick's result)."""
    core = Loop(Simulation(ContactAngle()), state_hz=60.0)
    tick_ns = 1_000_000
    now = 0
    for k in range(first, first + count):
        pos = sample_position(where, k)
        core.apply(TrackerSample(1, k, 0.0, list(pos), None, now), now)
        result, record = core.step(now)
        yield k, pos, state_map(record), result
        for _ in range(ticks_per_sample - 1):
            now += tick_ns
            core.step(now)
        now += tick_ns


def test_in_contact_every_sample_changes_the_cue_so_the_tick_that_applies_it_publishes_a_frame_showing_it():
    samples = list(_drive("contact", 0, 600))
    settled = samples[60:]  # after the contact gate's dwell (30 ms) and the first approach
    assert all(result.contact and result.output.cues for _, _, _, result in settled)
    assert all(result.cues_changed for _, _, _, result in settled)
    assert all(record is not None and tuple(record["hip"]) == pos for _, pos, record, _ in settled)


def test_in_free_space_nothing_is_touched_so_frames_only_come_on_the_cadence():
    samples = list(_drive("free", 0, 600))
    assert not any(result.contacts or result.contact or result.output.cues for _, _, _, result in samples)
    assert not any(result.cues_changed for _, _, _, result in samples[1:])
    # 17 ticks per sample against frames every 16-17 ticks: most samples' ticks publish nothing
    assert sum(record is not None for _, _, record, _ in samples) < len(samples)


@pytest.mark.parametrize("where", ["free", "contact"])
def test_any_consecutive_samples_have_distinct_positions_that_survive_the_loops_rounding(where):
    positions = [sample_position(where, k) for k in range(3 * TAG_PERIOD)]
    for start in (0, 500, 1999):
        assert len(set(positions[start:start + TAG_PERIOD])) == TAG_PERIOD
    assert all(tuple(round(v, 9) for v in p) == p for p in positions)


def test_an_unknown_path_is_refused():
    with pytest.raises(ValueError):
        sample_position("orbit", 0)


def test_each_sample_matches_the_first_frame_at_or_after_its_send_that_shows_its_position():
    a, b, c = (0.0, 0.1, 1.0), (0.0, 0.2, 1.0), (0.0, 0.3, 1.0)
    sent = [(100 * MS, a), (117 * MS, b), (134 * MS, c)]
    first_a, second_a, first_b = (105 * MS, a, 103 * MS), (121 * MS, a, 119 * MS), (123 * MS, b, 120 * MS)
    frames = [(90 * MS, (9.0, 9.0, 9.0), 88 * MS), first_a, second_a, first_b, (140 * MS, b, 137 * MS)]
    # a: the first of its two frames; b: 6 ms; c: never shown (superseded or lost)
    assert match_samples(sent, frames) == [first_a, first_b, None]


def test_a_frame_received_before_the_send_or_after_the_wait_limit_does_not_show_the_sample():
    pos = (0.0, 0.5, 1.0)
    sent = [(100 * MS, pos)]
    assert match_samples(sent, [(99 * MS, pos, 98 * MS)]) == [None], "a frame from before the send: an earlier sample"
    late = (100 * MS + 2_000 * MS, pos, 100 * MS + 1_999 * MS)
    assert match_samples(sent, [late], max_wait_ns=1_000 * MS) == [None], "the same position 1000 samples later"
    assert match_samples(sent, [(100 * MS, pos, 100 * MS)]) == [(100 * MS, pos, 100 * MS)]


def test_the_hip_of_a_decoded_frame_matches_whatever_sequence_type_it_arrives_in():
    sent = [(0, (0.0, 0.25, 1.000001))]
    frame = (5 * MS, [0, 0.25, 1.000001], 2 * MS)  # JSON: a list, 0.0 as 0
    assert match_samples(sent, [frame]) == [frame]


def test_summary_counts_samples_in_the_delayed_ack_band_and_the_superseded_and_splits_at_the_tick():
    latencies = [1, 2, 3, 4, 34.9, 35, 42, 50, 50.1]
    sent = [(1000 * MS * i, (0.0, 0.0, float(i))) for i in range(len(latencies) + 1)]
    # each frame carries the tick 0.5 ms after its send
    matches = [(t + round(v * MS), pos, t + MS // 2) for (t, pos), v in zip(sent, latencies)] + [None]
    summary = summarize(sent, matches)
    assert summary["samples"] == 10 and summary["shown"] == 9 and summary["superseded"] == 1
    assert summary["in_35_50_ms"] == sum(1 for v in latencies if BAND_MS[0] <= v <= BAND_MS[1]) == 3
    assert (summary["p50_ms"], summary["max_ms"]) == (34.9, 50.1)
    assert summary["to_tick_p50_ms"] == summary["to_tick_p99_ms"] == 0.5
    assert (summary["tick_to_client_p50_ms"], summary["tick_to_client_p99_ms"]) == (34.4, 49.6)
    assert summarize([], [])["p99_ms"] is None


def test_the_first_phase_waits_for_the_warm_up_and_later_ones_only_settle():
    plan = phase_plan(("free", "contact"), 20.0, 3.0)
    assert [p[0] for p in plan] == ["free", "contact"]
    assert plan[0][1:] == (3.0, 20.0) and 0 < plan[1][1] < 3.0 and plan[1][2] == 20.0


@pytest.mark.parametrize("kwargs", [{"seconds": 0}, {"clients": -1}, {"fmt": "xml"}, {"where": "orbit"},
                                    {"rate_hz": 0}, {"warmup_s": -1}, {"join": "middle"}])
def test_bad_arguments_are_refused_before_anything_starts(kwargs):
    with pytest.raises(ValueError):
        run_roundtrip_bench(**kwargs)


@pytest.mark.slow
@pytest.mark.parametrize(("fmt", "join"), [("json", "last"), ("msgpack", "first")])
def test_a_short_live_run_reports_round_trips_in_free_space_and_in_contact(fmt, join):
    result = run_roundtrip_bench(seconds=2, clients=2, fmt=fmt, where="both", warmup_s=1, join=join)
    print(f"\n{result}")
    assert (result["format"], result["clients"], result["join"]) == (fmt, 2, join)
    assert result["client_nodelay"] is True
    for where in ("free", "contact"):
        summary = result[where]
        assert summary["samples"] == 120
        assert summary["shown"] + summary["superseded"] == summary["samples"]
        assert summary["shown"] >= summary["samples"] // 2, summary
        assert 0 < summary["p50_ms"] <= summary["p99_ms"] <= summary["max_ms"] < 1000
        assert math.isfinite(summary["max_ms"])
        # both halves of the split at the loop tick are there, each shorter than the whole
        assert 0 < summary["to_tick_p50_ms"] < summary["p99_ms"]
        assert 0 < summary["tick_to_client_p50_ms"] < summary["p99_ms"]
    assert result["frames_sent_per_viewer_hz"] > 0 and result["viewer_frames_dropped"] >= 0
