"""Property tests (hypothesis) of the codec, the wire check and the I/O-free session: whatever a
client sends, the answer is a parsed message or a WireError, never another exception; a session
answers each frame with at most one error and keeps its queue bounded. Bounded and derandomized,
so CI runs the same examples every time."""

from __future__ import annotations

import json

import msgpack
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from server.hub.outbox import MAX_PENDING_ERRORS, Close
from server.hub.session import ServerInfo, Session
from server.wire import codec, messages
from server.wire.codec import WireError

FUZZ = settings(max_examples=400, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])

numbers = st.one_of(st.integers(min_value=-(2**70), max_value=2**70), st.floats(allow_nan=True, allow_infinity=True),
                    st.sampled_from([2**53, 2**64 - 1, -(2**63), 1e154, 1.35e154, 1e308, -1e308, 10.0, 10.000001]))
scalars = st.one_of(st.none(), st.booleans(), numbers, st.text(max_size=40))
values = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=5),
                                                       st.dictionaries(st.text(max_size=8), inner, max_size=5)),
                      max_leaves=30)
FIELDS = {"type": st.sampled_from(["hello", "tracker", "input", "state", "teleport"]) | st.text(max_size=10),
          "seq": values, "t": values, "pos": st.lists(numbers, min_size=0, max_size=4) | values,
          "quat": st.lists(numbers, min_size=4, max_size=4) | values, "key": values, "action": values,
          "value": values, "v": values, "role": values, "client": values}
# maps that look like client messages: the declared fields with any values, plus anything else
messageish = st.fixed_dictionaries({}, optional=FIELDS).flatmap(
    lambda m: st.dictionaries(st.text(max_size=6), values, max_size=3).map(lambda extra: {**extra, **m}))


def _parse(data, fmt):
    try:
        body = codec.decode(data, fmt)
        return messages.parse_client_message(body)
    except WireError as exc:
        assert exc.code in ("bad_encoding", "bad_message", "non_finite", "unknown_type", "too_large",
                            "out_of_range"), exc.code
        assert exc.message
        return exc


def _json(value) -> str:
    return json.dumps(value).replace("NaN", "1e999").replace("Infinity", "1e999")


@FUZZ
@given(st.binary(max_size=300))
def test_any_bytes_decode_to_a_message_or_a_wire_error(data):
    _parse(data, "msgpack")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        return
    _parse(text, "json")


@FUZZ
@given(messageish)
def test_any_message_like_map_parses_or_is_refused_with_a_code(body):
    for fmt in ("msgpack", "json"):
        try:
            data = msgpack.packb(body) if fmt == "msgpack" else _json(body)
        except (OverflowError, ValueError, TypeError):  # ints beyond 64 bits: msgpack cannot carry them
            continue
        result = _parse(data, fmt)
        if isinstance(result, messages.Tracker):
            assert all(abs(v) <= 10.0 for v in result.pos)
            assert 0 <= result.seq < 2**53


@FUZZ
@given(st.lists(st.tuples(st.sampled_from(["msgpack", "json"]), st.one_of(messageish, st.binary(max_size=60)),
                          st.integers(min_value=0, max_value=50_000_000)), max_size=60),
       st.sampled_from(["msgpack", "json"]))
def test_a_session_never_raises_answers_each_frame_once_and_stays_bounded(frames, fmt):
    s = Session(3, fmt, ServerInfo("viestac/fuzz", 1000, 60.0), 0)
    now = 0
    for kind, item, dt in frames:
        now += dt
        if isinstance(item, dict):
            try:
                data = msgpack.packb(item) if kind == "msgpack" else _json(item)
            except (OverflowError, ValueError, TypeError):
                continue
        else:
            data = item if kind == "msgpack" else item.decode("latin-1")
        errors_before = s.errors
        events = s.receive(data, now)
        assert s.errors - errors_before <= 1, "at most one error per frame"
        assert len(events) <= 1
        assert s.outbox._pending_errors <= MAX_PENDING_ERRORS and len(s.outbox._control) <= MAX_PENDING_ERRORS + 4
        if s.closing:
            break
    while (item := s.outbox.next_frame()) is not None:
        if not isinstance(item, Close):
            assert codec.decode(item, fmt)["type"] in ("welcome", "error")
