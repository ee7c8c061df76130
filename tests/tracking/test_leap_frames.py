from server.tracking import leap_frames as lf


def test_build_then_parse_round_trip():
    pts = {"right.index.tip": (10.0, 200.0, -5.0), "right.index.distal": (11.0, 195.0, 10.0),
           "right.thumb.tip": (-30.0, 190.0, 0.0), "right.thumb.metacarpal": (-20.0, 170.0, 40.0),
           "right.palm": (0.0, 180.0, 30.0), "left.index.tip": (-150.0, 210.0, 0.0)}
    frame = lf.build_frame(7, 123456, pts, confidence=0.8)
    assert lf.kind_of(frame) == "frame"
    got = lf.parse_frame(frame)
    assert got.frame_id == 7 and got.timestamp_us == 123456
    assert got.confidence == {"right": 0.8, "left": 0.8}
    for name, p in pts.items():
        assert got.points[name] == p


def test_hand_written_v6_frame():
    # as the service sends it (fields named in the leapjs v6 protocol); a tool and a stray pointable
    frame = {"id": 99, "timestamp": 5000000, "currentFrameRate": 111.2,
             "hands": [{"id": 42, "type": "right", "confidence": 0.93, "palmPosition": [1, 150, 2],
                        "wrist": [0, 140, 60]}],
             "pointables": [
                 {"id": 420, "handId": 42, "type": 0, "tipPosition": [-40, 160, -10], "dipPosition": [-35, 158, 0],
                  "pipPosition": [-30, 155, 10], "mcpPosition": [-25, 150, 30], "carpPosition": [-25, 150, 30]},
                 {"id": 421, "handId": 42, "type": 1, "tipPosition": [5, 170, -60], "dipPosition": [5, 168, -45],
                  "pipPosition": [5, 165, -25], "mcpPosition": [5, 160, 0], "carpPosition": [3, 145, 50]},
                 {"id": 9, "handId": 77, "type": 1, "tipPosition": [0, 0, 0]},
                 {"id": 10, "handId": 42, "type": 2, "tool": True, "tipPosition": [0, 0, 0]}]}
    got = lf.parse_frame(frame)
    assert got.points["right.index.tip"] == (5.0, 170.0, -60.0)
    assert got.points["right.index.metacarpal"] == (3.0, 145.0, 50.0)
    assert got.points["right.index.proximal"] == (5.0, 160.0, 0.0)
    assert got.points["right.thumb.metacarpal"] == (-25.0, 150.0, 30.0)  # the thumb's bones shift by one
    assert got.points["right.thumb.proximal"] == (-30.0, 155.0, 10.0)
    assert got.points["right.palm"] == (1.0, 150.0, 2.0)
    assert got.points["right.wrist"] == (0.0, 140.0, 60.0)
    assert "right.middle.tip" not in got.points
    assert got.frame_rate == 111.2


def test_message_kinds_and_bad_entries():
    assert lf.kind_of({"serviceVersion": "4", "version": 6}) == "version"
    assert lf.kind_of({"event": {"type": "deviceEvent"}}) == "event"
    got = lf.parse_frame({"hands": [{"id": 1, "type": "middle"}, {"id": 2, "type": "left", "palmPosition": [1, "x", 2]}],
                          "pointables": [{"handId": 2, "type": 9, "tipPosition": [0, 0, 0]},
                                         {"handId": 2, "type": 1, "tipPosition": [float("nan"), 0, 0]}]})
    assert got.points == {} and got.confidence == {"left": 1.0}


def test_two_right_hands_keep_the_confident_one():
    frame = {"hands": [{"id": 1, "type": "right", "confidence": 0.2}, {"id": 2, "type": "right", "confidence": 0.9}],
             "pointables": [{"handId": 1, "type": 1, "tipPosition": [1, 1, 1]},
                            {"handId": 2, "type": 1, "tipPosition": [2, 2, 2]}]}
    assert lf.parse_frame(frame).points["right.index.tip"] == (2.0, 2.0, 2.0)
