import pytest

from server.tracking import replay, scripted
from server.tracking.calibration import Calibration, leap_default
from server.tracking.pipeline import SourcePipeline, ttl_ms


def test_single_point_csv_is_the_primary_point():
    track = replay.parse_csv("t,x,y,z\n0,0,0,1\n0.01,0,0,0.9\n0.02,0,0,0.8\n")
    assert track.point_names == ("right.index.tip",)
    assert track.rows[2]["right.index.tip"] == (0.0, 0.0, 0.8)
    assert track.period_s == pytest.approx(0.01)


def test_multi_point_round_trip_and_errors():
    rows = [{"right.index.tip": (0.0, 0.1, 0.2), "right.thumb.tip": (1.0, 1.1, 1.2)},
            {"right.index.tip": (0.5, 0.1, 0.2), "right.thumb.tip": (1.5, 1.1, 1.2)}]
    text = replay.write_csv([0.0, 0.01], rows)
    assert text.splitlines()[0].startswith("t,right.index.tip.x,right.index.tip.y")
    track = replay.parse_csv(text)
    assert list(track.rows) == rows
    with pytest.raises(ValueError, match="not a tracked point"):
        replay.parse_csv("t,right.indx.tip.x,right.indx.tip.y,right.indx.tip.z\n0,0,0,0\n")
    with pytest.raises(ValueError, match="lacks"):
        replay.parse_csv("t,right.index.tip.x,right.index.tip.y\n0,0,0\n")
    with pytest.raises(ValueError, match="go back"):
        replay.parse_csv("t,x,y,z\n1,0,0,0\n0.5,0,0,0\n")


def test_cursor_once_and_loop():
    track = replay.parse_csv("t,x,y,z\n10,0,0,0\n10.1,0,0,1\n10.2,0,0,2\n")
    once = replay.ReplayCursor(track, loop=False)
    assert [i for i, _ in once.due(0.0)] == [0]
    assert [i for i, _ in once.due(0.15)] == [1]
    assert [i for i, _ in once.due(5.0)] == [2] and once.done
    looped = replay.ReplayCursor(track, loop=True)
    got = [i for i, _ in looped.due(0.61)]  # a pass lasts 0.2 s + one 0.1 s period
    assert got == [0, 1, 2, 0, 1, 2, 0] and looped.passes == 2


def test_scripted_tap_touches_the_dome():
    depths = [scripted.DOME_RADIUS + scripted.HIP_RADIUS - sum(v * v for v in scripted.tap(t / 100)["right.index.tip"]) ** 0.5
              for t in range(0, 750)]
    assert max(depths) == pytest.approx(0.01) and min(depths) < -0.1
    with pytest.raises(ValueError, match="one of"):
        scripted.script("nope")


def test_pipeline_datagram_fields_and_ttl():
    assert ttl_ms(110) == pytest.approx(4000 / 110)
    assert ttl_ms(1000) == 20.0 and ttl_ms(30) == 60.0
    pipe = SourcePipeline("leap", leap_default(), nominal_hz=110, filter_params=None)
    msg = pipe.process({"right.index.tip": (0.0, 200.0, 0.0), "right.thumb.tip": (-20.0, 200.0, 0.0)}, 1.5)
    assert msg["type"] == "tracker" and msg["seq"] == 1 and msg["t"] == 1500.0
    assert msg["point"] == "right.index.tip" and msg["pos"] == pytest.approx([0.0, 0.0, 0.35])
    assert msg["points"]["right.thumb.tip"] == pytest.approx([0.0, -0.1, 0.35])
    assert msg["ttl"] == pytest.approx(36.36, abs=0.01)


def test_pipeline_left_hand_only_and_outside_workspace():
    pipe = SourcePipeline("s", Calibration(), nominal_hz=120, filter_params=None)
    msg = pipe.process({"left.palm": (0.0, 0.0, 0.0), "left.index.tip": (0.1, 0.0, 0.0)}, 0.0)
    assert msg["point"] == "left.index.tip" and msg["points"] == {"left.palm": [0.0, 0.0, 0.0]}
    assert pipe.process({"right.index.tip": (50.0, 0.0, 0.0)}, 0.01) is None and pipe.outside == 1


def test_pipeline_filters_each_point():
    pipe = SourcePipeline("s", Calibration(), nominal_hz=100)
    pipe.process({"right.index.tip": (0.0, 0.0, 0.0)}, 0.0)
    msg = pipe.process({"right.index.tip": (0.0, 0.0, 0.01)}, 0.01)
    assert 0.0 < msg["pos"][2] < 0.01


def test_a_looping_replays_row_times_keep_rising_across_passes():
    """The filters see the source's clock: the last row of a pass must not carry the next pass's
    start (it did: every row of the second pass then came 'before' it and the HIP froze)."""
    from server.tracking.replay import ReplayCursor, parse_csv
    track = parse_csv("t,x,y,z\n0,0,0,1\n0.01,0,0,1.1\n0.02,0,0,1.2\n")
    cursor = ReplayCursor(track, loop=True)
    times = []
    for k in range(9):
        if cursor.due(k * 0.01 + 1e-9):
            times.append(cursor.last_time)
    assert times == sorted(times) and len(set(times)) == len(times) == 9, times
    assert times[3] == pytest.approx(0.03), "the second pass starts one period after the first's last row"
