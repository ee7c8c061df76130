"""Loop timing statistics on the hub side, against numpy computed independently."""

from array import array

import numpy as np

from server.hub.telemetry import LoopTelemetry


def _pack(periods_us, costs_us, published=None) -> bytes:
    samples = array("q")
    for i, (p, c) in enumerate(zip(periods_us, costs_us)):
        samples.extend((int(p * 1000), int(c * 1000), int(published[i]) if published is not None else 0))
    return samples.tobytes()


def test_window_and_cumulative_statistics():
    rng = np.random.default_rng(3)
    periods = np.clip(rng.normal(1000, 15, 30_000), 900, None).round()
    periods[[100, 5000, 29_000]] = [1600, 2500, 1400]  # two overruns (> 1.5 ms) and a near miss
    costs = rng.gamma(2.0, 12.0, 30_000).round()
    telemetry = LoopTelemetry(window_s=10.0)
    for start in range(0, 30_000, 17):  # in state-record-sized batches
        telemetry.add(_pack(periods[start:start + 17], costs[start:start + 17]))
    window = telemetry.window()
    last = periods[-10_000:]
    assert window["ticks"] == 30_000
    assert window["period_p99_us"] == round(float(np.percentile(last, 99)), 1)
    assert window["period_max_us"] == float(last.max())
    assert window["overruns"] == 0  # both overruns are older than the 10 s window
    cumulative = telemetry.cumulative()
    assert cumulative["ticks"] == 30_000 and cumulative["overruns"] == 2
    assert cumulative["period_max_us"] == 2500.0
    assert abs(cumulative["period_p99_us"] - np.percentile(periods, 99)) <= 1.0  # 1 µs bins
    assert abs(cumulative["tick_cost_p50_us"] - np.percentile(costs, 50)) <= 1.0
    telemetry.reset_cumulative()
    telemetry.add(_pack([1000, 3000], [10, 20]))
    after = telemetry.cumulative()
    assert after["ticks"] == 2 and after["overruns"] == 1 and after["period_max_us"] == 3000.0


def test_the_costs_of_publishing_ticks_and_of_the_others_are_told_apart():
    rng = np.random.default_rng(5)
    n = 12_000
    published = rng.random(n) < 0.17  # about one tick in six publishes, as at 64 viewers
    costs = np.where(published, rng.gamma(4.0, 25.0, n), rng.gamma(2.0, 4.0, n)).round()
    telemetry = LoopTelemetry()
    for start in range(0, n, 23):
        telemetry.add(_pack(np.full(23, 1000.0)[:n - start], costs[start:start + 23], published[start:start + 23]))
    got = telemetry.cumulative()
    assert got["ticks"] == n and got["published_ticks"] == int(published.sum())
    for kind, mask in (("published", published), ("quiet", ~published)):
        for q in (50, 99):
            # whole-µs costs in 1 µs bins: the smallest cost with at least q % of the ticks at or below it
            assert got[f"tick_cost_{kind}_p{q}_us"] == np.percentile(costs[mask], q, method="inverted_cdf"), (kind, q)
    assert got["tick_cost_quiet_p99_us"] < got["tick_cost_p99_us"] < got["tick_cost_published_p99_us"]


def test_empty_telemetry_is_all_zero():
    telemetry = LoopTelemetry()
    assert telemetry.window()["ticks"] == 0 and telemetry.cumulative()["period_p99_us"] == 0.0
    telemetry.add(b"")
    assert telemetry.ticks == 0
