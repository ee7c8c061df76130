"""Issue 18 in the I/O-free session: the input budget (defect 6), bad frames that once escaped
as exceptions (defect 8), one size and one non-finite rule for both encodings (defect 9), and
the workspace bound (defect 1 at the edge). Each bad frame gets exactly one `error` and the
session goes on."""

from __future__ import annotations

import json

import msgpack
import pytest

from server.hub.input_budget import INPUT_BURST, INPUT_RATE_PER_S, RATE_LIMITED_ERROR_EVERY_NS
from server.hub.outbox import Close
from server.hub.session import Command, ServerInfo, Session, ToLoop
from server.wire import codec, messages
from tests.hub.access_fakes import ADMIN_SECRET, gate

SERVER = ServerInfo("viestac/test", 1000, 60.0)
T0 = 5_000_000_000
MS = 1_000_000


def welcomed(fmt: str = "msgpack") -> Session:
    s = Session(7, fmt, SERVER, T0, gate=gate()[0])
    hello = {"type": "hello", "v": 1, "role": "participant", "client": "pytest", "token": ADMIN_SECRET}
    s.receive(msgpack.packb(hello) if fmt == "msgpack" else json.dumps(hello), T0)
    drain(s)
    return s


def drain(session: Session) -> list:
    out = []
    while (item := session.outbox.next_frame()) is not None:
        out.append(item if isinstance(item, Close) else codec.decode(item, session.fmt))
    return out


def key(fmt: str = "msgpack", k: str = "ArrowUp") -> bytes | str:
    body = {"type": "input", "key": k, "action": "press"}
    return msgpack.packb(body) if fmt == "msgpack" else json.dumps(body)


# ---- defect 6: the input budget --------------------------------------------------------------

def test_a_burst_passes_then_inputs_over_budget_are_refused_with_one_error_a_second():
    s = welcomed()
    forwarded = [e for _ in range(INPUT_BURST) for e in s.receive(key(), T0)]
    assert len(forwarded) == INPUT_BURST and all(isinstance(e, Command) for e in forwarded)
    assert drain(s) == []
    refused = [s.receive(key(), T0 + i) for i in range(100)]
    assert refused == [[]] * 100, "over budget: nothing reaches the loop"
    errors = drain(s)
    assert [(m["type"], m["code"]) for m in errors] == [("error", "rate_limited")], "one error a second"
    assert s.info()["rate_limited"] == 100 and s.errors == 100
    # 1 s later: a second's worth of tokens (capped at the burst) and one more error allowed
    later = T0 + RATE_LIMITED_ERROR_EVERY_NS
    assert sum(len(s.receive(key(), later)) for _ in range(INPUT_BURST + 5)) == INPUT_BURST
    assert [m["code"] for m in drain(s)] == ["rate_limited"]


def test_ten_thousand_key_presses_a_second_reach_the_loop_at_the_budgeted_rate():
    s = welcomed("json")
    forwarded = 0
    for i in range(10_000):  # 10 kHz for one second
        forwarded += len(s.receive(key("json"), T0 + i * 100_000))
    assert forwarded <= INPUT_BURST + INPUT_RATE_PER_S + 1
    assert forwarded >= INPUT_RATE_PER_S  # a person's rate always passes
    errors = drain(s)
    assert 1 <= len(errors) <= 2 and {m["code"] for m in errors} == {"rate_limited"}


def test_a_steady_person_is_never_limited():
    s = welcomed()
    for i in range(2000):  # 40 key events a second for 50 s
        assert len(s.receive(key(), T0 + i * 25 * MS)) == 1
    assert s.rate_limited == 0 and drain(s) == []


def test_trackers_are_not_budgeted():
    s = welcomed()
    tracker = msgpack.packb({"type": "tracker", "seq": 1, "t": 0, "pos": [0.1, 0.2, 0.3]})
    assert all(isinstance(s.receive(tracker, T0)[0], ToLoop) for _ in range(500))


def test_a_flood_of_events_is_bounded_on_the_wire_and_kept_whole_for_the_recorder():
    events = [{"tick": i, "t": i / 1000, "name": "input", "key": "x"} for i in range(5000)]
    events.insert(2500, {"tick": 2500, "t": 2.5, "name": "trial_done"})
    record = {"frame": 1, "tick": 1, "t": 0.0, "scene": "aaaa", "hip": [0, 0, 0], "proxy": [0, 0, 0],
              "force": [0, 0, 0], "contact": False, "contacts": [], "objects": [], "cues": [], "hud": "",
              "values": {}, "events": events, "visible": {}, "scales": {}, "stiffness": {}, "haptic": {},
              "driver": None, "tools": [], "points": {}, "tracking": {"lost": []}}
    before = list(events)
    wire = messages.state_message(record, {})["events"]
    assert len(wire) == messages.MAX_WIRE_EVENTS
    assert {"tick": 2500, "t": 2.5, "name": "trial_done"} in wire, "scenario events go before inputs"
    assert wire[-1] == events[-1] and [e["tick"] for e in wire] == sorted(e["tick"] for e in wire)
    assert record["events"] == before, "the record (what the recorder reads) keeps every event"
    few = events[:5]
    assert messages.state_message({**record, "events": few}, {})["events"] == few
    size = len(codec.encode(messages.state_message(record, {}), "json"))
    assert size < 4000, size


# ---- defect 8: frames that once raised --------------------------------------------------------

def _nested(depth: int) -> str:
    return "[" * depth + "]" * depth


FRAMES_8 = {
    "pos 995 deep": ('{"type":"tracker","seq":1,"t":0,"pos":' + _nested(995) + "}", "bad_message"),
    "pos 100000 deep": ('{"type":"tracker","seq":1,"t":0,"pos":' + _nested(20_000) + "}", "bad_message"),
    "seq 2^64": (json.dumps({"type": "tracker", "seq": 2**64, "t": 0, "pos": [0, 0, 0]}), "out_of_range"),
    "t 400 digits": ('{"type":"tracker","seq":1,"t":' + "9" * 400 + ',"pos":[0,0,0]}', "non_finite"),
    "pos 400 digits": ('{"type":"tracker","seq":1,"t":0,"pos":[0,' + "9" * 400 + ',0]}', "non_finite"),
    "quat 400 digits": ('{"type":"tracker","seq":1,"t":0,"pos":[0,0,0],"quat":[' + "9" * 400 + ",0,0,0]}",
                        "non_finite"),
    "value 400 digits": ('{"type":"input","key":"a","action":"press","value":' + "9" * 400 + "}", "non_finite"),
    "unknown field 5000 digits": ('{"type":"input","key":"a","action":"press","x":' + "9" * 5000 + "}",
                                  "non_finite"),
}


@pytest.mark.parametrize("name", FRAMES_8)
def test_a_frame_that_once_raised_gets_one_error_and_the_session_goes_on(name):
    data, code = FRAMES_8[name]
    s = welcomed("json")
    assert s.receive(data, T0) == []
    assert [(m["type"], m["code"]) for m in drain(s)] == [("error", code)]
    assert isinstance(s.receive(key("json"), T0)[0], Command), "the session still serves"


def test_msgpack_nested_deep_gets_one_error():
    s = welcomed()
    for depth in (40, 995, 5000):
        pos = b"\x91" * depth + b"\x00"
        data = b"\x84\xa4type\xa7tracker\xa3seq\x01\xa1t\x00\xa3pos" + pos
        assert s.receive(data, T0) == []
        assert [m["code"] for m in drain(s)] == ["bad_message"], depth


# ---- defect 9: one rule for both encodings ----------------------------------------------------

def test_the_size_limit_counts_encoded_bytes_in_json_too():
    # 65,061 characters of which most take 4 UTF-8 bytes: ~260 KB on the wire
    pad = "😀" * (65_061 - len('{"type":"input","key":"a","action":"down","pad":""}'))
    text = '{"type":"input","key":"a","action":"down","pad":"' + pad + '"}'
    assert len(text) == 65_061 and len(text.encode()) > 4 * 64_000
    s = welcomed("json")
    assert s.receive(text, T0) == []
    assert [m["code"] for m in drain(s)] == ["too_large"]
    # what fits in bytes still passes, however it is spelt
    ok = '{"type":"input","key":"a","action":"down","pad":"' + "é" * 30_000 + '"}'
    assert len(ok.encode()) < codec.MAX_FRAME_BYTES and isinstance(s.receive(ok, T0)[0], Command)


@pytest.mark.parametrize("fmt", ["json", "msgpack"])
def test_infinity_in_an_unknown_field_is_refused_in_both_encodings(fmt):
    s = welcomed(fmt)
    body = {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 0], "extra": {"x": [float("inf")]}}
    data = msgpack.packb(body) if fmt == "msgpack" else json.dumps(body).replace("Infinity", "1e999")
    assert s.receive(data, T0) == []
    assert [m["code"] for m in drain(s)] == ["non_finite"]


# ---- defect 1 at the edge: the workspace -------------------------------------------------------

@pytest.mark.parametrize("pos", [[0, 1e154, 0.5], [0, 1.35e154, 0.5], [10.5, 0, 0], [0, 0, -1e308]])
def test_a_position_outside_the_workspace_is_refused_and_never_reaches_the_loop(pos):
    s = welcomed()
    assert s.receive(msgpack.packb({"type": "tracker", "seq": 1, "t": 0, "pos": pos}), T0) == []
    assert [m["code"] for m in drain(s)] == ["out_of_range"]
    inside = s.receive(msgpack.packb({"type": "tracker", "seq": 2, "t": 0, "pos": [0.1, 0.1, 0.5]}), T0)
    assert isinstance(inside[0], ToLoop) and inside[0].record.pos == [0.1, 0.1, 0.5]


@pytest.mark.parametrize("fmt", codec.FORMATS)
def test_an_error_reply_never_echoes_a_huge_value_whole(fmt):
    """Issue 35 point 7: an `unknown_type` reply repeated a 60,000-character type (60,111 bytes)."""
    s = welcomed(fmt)
    huge = "x" * 60_000
    frame = {"type": huge, "seq": 1}
    s.receive(msgpack.packb(frame) if fmt == "msgpack" else json.dumps(frame), T0 + MS)
    [reply] = drain(s)
    assert reply["type"] == "error" and reply["code"] == "unknown_type"
    assert len(reply["message"]) <= 200 and "60000 characters" in reply["message"]
    assert "expected one of" in reply["message"], "the useful part of the text survives the cut"
    assert len(codec.encode(reply, fmt)) < 300


def test_every_error_text_is_bounded_where_error_messages_are_built():
    from server.wire.schema import MAX_ERROR_MESSAGE_CHARS

    message = messages.error("bad_message", "y" * 10_000)
    assert len(message["message"]) == MAX_ERROR_MESSAGE_CHARS and message["message"].endswith("…")
    assert messages.error("bad_message", "short")["message"] == "short"
