"""A /ws tracker of protocol v1.4 (several points of a hand, the point `pos` is, a ttl) reaches
the loop as the same record the tracker UDP port makes (server/wire/messages.py loop_record)."""

from __future__ import annotations

import json

import pytest

from server.hub.session import ToLoop
from tests.hub.test_session import T0, frame, hello, new, sent
from server.ipc.records import TrackerSample

HAND = {"type": "tracker", "seq": 5, "t": 10.0, "pos": [0, 0.1, 0.6], "point": "right.index.tip",
        "points": {"right.thumb.tip": [0, 0.2, 0.6], "right.wrist": [0, 0.1, 0.9]}, "ttl": 33.3}


@pytest.mark.parametrize("fmt", ["msgpack", "json"])
def test_a_hand_sample_becomes_a_loop_record_with_its_points_and_ttl(fmt):
    s = new(fmt)
    s.receive(hello(fmt=fmt), T0)
    events = s.receive(frame(HAND, fmt), T0 + 9)
    assert events == [ToLoop(TrackerSample(7, 5, 10.0, [0.0, 0.1, 0.6], None, T0 + 9, "right.index.tip", {"right.thumb.tip": [0.0, 0.2, 0.6], "right.wrist": [0.0, 0.1, 0.9]}, 33.3),
                             busy="the loop's input mailbox is full; tracker sample dropped")]


@pytest.mark.parametrize("change, code", [
    ({"point": "right.index.nail"}, "bad_message"),
    ({"points": {"right.thumb.tip": [0, 11, 0]}}, "out_of_range"),
    ({"ttl": 0}, "bad_message"),
])
def test_a_bad_v14_field_gets_one_error_and_nothing_reaches_the_loop(change, code):
    s = new("json")
    s.receive(hello(fmt="json"), T0)
    sent(s)
    assert s.receive(json.dumps({**HAND, **change}), T0 + 1) == []
    assert [m["code"] for m in sent(s)] == [code]
