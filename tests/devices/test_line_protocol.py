"""LineProtocol: DeviceSession's interface over ASCII line templates."""

import tomllib

import pytest
from hypothesis import given
from hypothesis import strategies as st

from devices.line_protocol import CommandRefused, DeviceLine, LineProfile, LineProfileError, LineProtocol
from devices.messages import SetFriction, SetPattern, SetTemperature, SetTilt, Stop
from devices.protocol import FrameRejected, StatusChanged

TEMPLATES = {
    "pulse": "P,{on_ms},{off_ms},{intensity}\n",
    "continuous": "C,{intensity}\n",
    "texture": "T,{period_us},{on_us}\n",
    "off": "S\n",
    "tilt": "D,{direction_deg},{magnitude}\n",
}


def drain(proto, t: float = 0.0, until: float = 1.0) -> list[tuple[float, bytes]]:
    """Poll as an adapter would, honouring the wake-up times; returns the writes."""
    writes = []
    while t <= until:
        data, wake = proto.poll(t)
        if data:
            writes.append((t, data))
            continue
        if wake is None:
            break
        assert wake > t
        t = wake
    return writes


def lines(writes) -> list[str]:
    return [d.decode("ascii") for _, d in writes]


def test_rendering_in_human_units():
    profile = LineProfile.from_dict(TEMPLATES)
    assert profile.render(SetPattern.pulse(0, 50, 200, 100)) == "P,50,200,100\n"
    assert profile.render(SetPattern.pulse(0, 1.5, 0.25, 30)) == "P,1.5,0.25,30\n"
    assert profile.render(SetPattern.texture(0, 2000, 0.25, 100)) == "T,2000,500\n"
    assert profile.render(SetPattern.continuous(1, 75)) == "C,75\n"
    assert profile.render(SetPattern.off(0)) == "S\n"
    assert profile.render(SetTilt.from_degrees(0, 90, 100)) == "D,90,100\n"
    assert profile.render(SetTilt.from_degrees(0, 45.5, 50)) == "D,45.5,50\n"
    assert profile.render(SetTemperature(0, 3200)) is None


def test_stop_uses_its_template_or_the_off_lines():
    assert LineProfile.from_dict(TEMPLATES).render(Stop(0)) == "S\nD,0,0\n"
    assert LineProfile.from_dict({**TEMPLATES, "stop": "X,{channel}\n"}).render(Stop(0xFF)) == "X,255\n"
    assert LineProfile.from_dict({"continuous": "C\n"}).render(Stop(0)) is None


def test_more_fields_and_format_specs():
    profile = LineProfile.from_dict({"temperature": "H{channel},{celsius:.2f},{centi_celsius}\n",
                                     "friction": "F,{coefficient},{milli:05d}\n"})
    assert profile.render(SetTemperature(1, 3250)) == "H1,32.50,3250\n"
    assert profile.render(SetFriction(0, 500)) == "F,0.5,00500\n"


@pytest.mark.parametrize("data, words", [
    ({"pulse": "P,{on_sec}\n"}, ["'pulse'", "{on_sec}", "{on_ms}", "{intensity}"]),
    ({"tilt": "D,{}\n"}, ["'tilt'", "{direction_deg}"]),
    ({"tilt": "D,{direction_deg.real}\n"}, ["{direction_deg.real}"]),
    ({"pulse": "P,{on_ms:d}\n"}, ["'pulse'", "on_ms:d"]),           # 1.5 ms cannot be formatted with :d
    ({"pulse": "P,{on_ms}"}, ["'pulse'", "newline"]),
    ({"pulse": "P,{on_ms\n"}, ["'pulse'"]),
    ({"pulse": "P,\u00b5s\n"}, ["ASCII"]),
    ({"pulse": 5}, ["string"]),
    ({"puls": "P\n"}, ["'puls'", "did you mean 'pulse'"]),
    ({"hello_reply": "OK"}, ["hello_reply needs a hello"]),
    ({"hello": "?\n", "hello_reply": "(", "off": "S\n"}, ["hello_reply", "regular expression"]),
    ({"hello": "?\n"}, ["no command templates"]),
])
def test_bad_profiles_say_what_is_wrong(data, words):
    with pytest.raises(LineProfileError) as info:
        LineProfile.from_dict(data)
    for word in words:
        assert word in str(info.value)


def test_profile_from_toml():
    text = r'''
    [line]
    pulse = "P,{on_ms},{off_ms},{intensity}\n"
    off = "S\n"
    hello = "?\n"
    hello_reply = "^LAB-VIBE"
    '''
    profile = LineProfile.from_dict(tomllib.loads(text)["line"])
    assert profile.templates["hello"] == "?\n" and profile.hello_reply.pattern == "^LAB-VIBE"


def test_connected_at_once_without_a_hello():
    proto = LineProtocol(TEMPLATES)  # a plain mapping, as devices/manager.py passes it
    assert proto.poll(0.0) == (b"", None)
    proto.connection_made(0.0)
    assert [e.new for e in proto.events_received()] == ["connected"]
    proto.set(SetPattern.pulse(0, 50, 200, 100), 0.0)
    assert lines(drain(proto)) == ["P,50,200,100\n"]


def test_hello_until_the_reply_matches():
    proto = LineProtocol({**TEMPLATES, "hello": "?\n", "hello_reply": "^LAB"})
    proto.connection_made(0.0)
    writes = drain(proto, 0.0, 0.6)
    assert [(t, d) for t, d in writes] == [(0.0, b"?\n"), (0.25, b"?\n"), (0.5, b"?\n")]
    proto.receive_data(b"noise\r\nLAB-VIBE v2\r\n", 0.6)
    events = proto.events_received()
    assert [e.text for e in events if isinstance(e, DeviceLine)] == ["noise", "LAB-VIBE v2"]
    assert [e.new for e in events if isinstance(e, StatusChanged)] == ["handshaking", "connected"]
    assert drain(proto, 0.7, 2.0) == []


def test_hello_without_a_reply_connects_once_written():
    proto = LineProtocol({**TEMPLATES, "hello": "HI\n"})
    proto.connection_made(0.0)
    assert lines(drain(proto)) == ["HI\n"]
    assert proto.status == "connected"


def test_a_layer_without_a_template_is_refused_loudly():
    proto = LineProtocol(TEMPLATES)
    proto.connection_made(0.0)
    proto.events_received()
    proto.set(SetTemperature(0, 3200), 0.0)
    proto.set(SetPattern.pulse(0, 50, 200, 100), 0.0)
    (refused,) = proto.events_received()
    assert isinstance(refused, CommandRefused) and "SetTemperature" in refused.reason
    assert proto.counters["refused"] == 1
    assert lines(drain(proto)) == ["P,50,200,100\n"]
    proto2 = LineProtocol({"pulse": "P\n"})
    proto2.set(SetPattern.continuous(0, 50), 0.0)
    assert "'continuous'" in proto2.events_received()[0].reason


def test_latest_wins_and_the_budget_spaces_lines():
    proto = LineProtocol(TEMPLATES)
    proto.connection_made(0.0)
    for i in range(10):
        proto.set(SetPattern.pulse(0, 10 + i, 200, 100), 0.0)
    proto.set(SetTilt.from_degrees(0, 90, 100), 0.0)
    writes = drain(proto)
    assert lines(writes) == ["P,19,200,100\n", "D,90,100\n"]
    assert writes[1][0] == pytest.approx(len(writes[0][1]) * 86.8e-6 / 0.5)
    proto.set(SetTilt.from_degrees(0, 90, 100), 1.0)
    assert drain(proto, 1.0, 2.0) == []  # already written
    assert proto.counters["frames_out"] == 2 and proto.counters["bytes_out"] == sum(len(d) for _, d in writes)


def test_everything_is_written_again_after_a_reconnect():
    proto = LineProtocol(TEMPLATES)
    proto.connection_made(0.0)
    proto.set(SetTilt.from_degrees(0, 90, 100), 0.0)
    proto.set(SetPattern.continuous(0, 50), 0.0)
    drain(proto)
    proto.connection_lost(1.0, "read failed")
    assert proto.poll(1.0) == (b"", None)
    proto.connection_made(2.0)
    assert lines(drain(proto, 2.0, 3.0)) == ["D,90,100\n", "C,50\n"]


def test_a_too_long_device_line_is_rejected_and_the_next_one_read():
    proto = LineProtocol(TEMPLATES)
    proto.connection_made(0.0)
    proto.events_received()
    proto.receive_data(b"x" * 300, 0.1)
    proto.receive_data(b"y" * 10 + b"\nOK\n", 0.1)
    events = proto.events_received()
    assert isinstance(events[0], FrameRejected) and events[0].error.kind == "too_long"
    assert events[1:] == [DeviceLine("OK")]


@given(st.lists(st.binary(max_size=400), max_size=6))
def test_arbitrary_bytes_never_raise(chunks):
    proto = LineProtocol({**TEMPLATES, "hello": "?\n", "hello_reply": "OK"})
    proto.connection_made(0.0)
    for chunk in chunks:
        proto.receive_data(chunk, 0.1)
        proto.poll(0.1)
    for event in proto.events_received():
        assert isinstance(event, (DeviceLine, FrameRejected, StatusChanged))
