import json

from server.bench import tracking_bench as tb
from server.cli import main


def test_paths_are_deterministic_and_touch_the_surface():
    t, p, label = tb.true_path(5, 6.0)
    t2, p2, _ = tb.true_path(5, 6.0)
    assert (p == p2).all()
    assert (p[:, 2] < 0).any() and (p[:, 2] > 0.05).any() and (label >= 0).any() and (label < 0).any()


def test_filters_beat_raw_on_jitter_and_chatter(tmp_path):
    result = tb.filter_study(seeds=(1,), seconds=2 * tb.SEGMENT_S)
    by = {f["name"]: f for f in result["filters"]}
    raw, default = by["raw"], by["1euro-default"]
    assert raw["lag_ms"] == 0.0 and raw["chatter"] > 1.5  # noise at a light touch makes contact flicker
    assert default["jitter"] < raw["jitter"] / 3 and default["chatter"] < raw["chatter"]
    assert by["ma16"]["lag_ms"] > by["ma2"]["lag_ms"]  # a longer average lags more
    tb.chart(result, tmp_path / "c.png")
    assert (tmp_path / "c.png").stat().st_size > 10_000


def test_cli_prints_json_and_writes_the_chart(tmp_path, capsys):
    assert main(["bench", "tracking", "--out", str(tmp_path), "--latency-seconds", "0", "--json"]) == 0
    printed = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert printed["filters"]["defaults_on_front"] is True
    assert (tmp_path / "tracking_filters.png").is_file() and (tmp_path / "tracking.json").is_file()


def test_the_latency_part_measures_leap_sample_to_device_command_through_a_live_server(tmp_path, capsys):
    """A short run of the end-to-end part (the bench's default is 130 s for > 1000 switches)."""
    assert main(["bench", "tracking", "--out", str(tmp_path), "--latency-seconds", "4", "--viewers", "2",
                 "--json"]) == 0
    latency = json.loads(capsys.readouterr().out.strip().splitlines()[-1])["latency"]
    assert latency["samples"] > 0 and latency["viewers"] == 2
    assert 0 < latency["p50_ms"] <= latency["p99_ms"] <= latency["max_ms"]
    assert "p99_ci95_ms" in latency
