"""Messages of the device protocol (docs/device-protocol.md §2–§3): vectors, range checks,
human-unit constructors and the layer semantics used for coalescing."""

import json
from dataclasses import asdict
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from devices import messages as m
from devices.messages import (ALL_CHANNELS, Caps, Error, ErrorCode, Identify, MessageError, PatternMode, SetFriction,
                              SetPattern, SetTemperature, SetTilt, Stop, as_seen_by, overrides, touches, unpack)

VECTORS = json.loads((Path(__file__).parents[1] / "vectors" / "device_frames.json").read_text())


@pytest.mark.parametrize("v", VECTORS["frames"], ids=lambda v: v["name"])
def test_vector_payloads_pack_and_unpack(v):
    payload = bytes.fromhex(v["payload_hex"])
    message = unpack(v["type"], payload)
    fields = asdict(message)
    if isinstance(message, Identify):
        fields["model_len"] = len(message.model)
    assert fields == v["fields"]
    assert message.pack() == payload
    assert type(message).TYPE == v["type"]
    assert message.FROM_HOST == (v["direction"] == "host")
    assert type(message)(**{k: x for k, x in v["fields"].items() if k != "model_len"}) == message


def test_identify_examples_of_the_doc():
    ferrovibe = next(v for v in VECTORS["frames"] if v["name"] == "identify_ferrovibe")
    identity = unpack(ferrovibe["type"], bytes.fromhex(ferrovibe["payload_hex"]))
    assert identity.caps == Caps.PULSE | Caps.CONTINUOUS | Caps.TEXTURE | Caps.TILT == 0x0F
    assert (identity.channels, identity.carrier_hz, identity.model, identity.firmware) == (1, 235, "ferrovibe", "1.0.0")


@pytest.mark.parametrize("make, field", [
    (lambda: SetPattern(0, 1, 101, 0, 1, 1), "intensity"),
    (lambda: SetPattern(0, 4, 50, 0, 1, 1), "mode"),
    (lambda: SetPattern(0, 1, 50, 0, 60_000_001, 1), "on_us"),
    (lambda: SetPattern(0, 1, 50, 70_000, 1, 1), "carrier_hz"),
    (lambda: SetPattern(0, 1, 50.0, 0, 1, 1), "intensity"),
    (lambda: SetPattern(256, 1, 50, 0, 1, 1), "channel"),
    (lambda: SetTilt(0, 36_000, 50), "direction_cdeg"),
    (lambda: SetTilt(0, 100, -1), "magnitude"),
    (lambda: SetTemperature(0, 5001), "centi_celsius"),
    (lambda: SetTemperature(0, -1), "centi_celsius"),
    (lambda: SetFriction(0, 5001), "milli"),
    (lambda: Stop(True), "channel"),
    (lambda: m.Ping(2 ** 32), "token"),
    (lambda: Identify(1, 1, 0, 0, 0, 7, 235, "fingertac"), "channels"),
    (lambda: Identify(1, 1, 0, 0, 2, 7, 235, "FingerTac"), "model"),
    (lambda: Identify(1, 1, 0, 0, 2, 7, 235, ""), "model"),
    (lambda: Identify(1, 1, 0, 0, 2, 7, 235, "x" * 33), "model"),
    (lambda: SetPattern.pulse(0, float("nan"), 10, 50), "on_us"),
    (lambda: SetPattern.texture(0, 2000, 1.5, 50), "duty"),
    (lambda: SetTilt.from_degrees(0, float("inf"), 50), "direction_cdeg"),
])
def test_bad_values_name_their_field(make, field):
    with pytest.raises(ValueError, match=field) as info:
        make()
    assert info.value.kind == "bad_value" and info.value.field == field


@pytest.mark.parametrize("type_, payload, kind", [
    (0x7E, b"", "unknown_type"),
    (0x11, b"\x00\x28\x23", "bad_length"),
    (0x10, bytes(14), "bad_length"),
    (0x83, b"", "bad_length"),
    (0x81, bytes([1, 1, 0, 0, 2, 7, 235, 0, 9]) + b"fingerta", "bad_length"),  # model_len says 9, 8 follow
    (0x81, bytes([1, 1, 0, 0, 2, 7, 235, 0, 2]) + b"\xff\xfe", "bad_value"),
    (0x11, bytes([0, 0xA0, 0x8C, 50]), "bad_value"),                           # 36000 cdeg
])
def test_unpack_classifies(type_, payload, kind):
    with pytest.raises(MessageError) as info:
        unpack(type_, payload)
    assert info.value.kind == kind


def test_forward_compatible_values_are_kept():
    # §6: new caps bits and (we assume) new error codes must not break an older host
    assert unpack(0x84, bytes([3, 42])) == Error(3, 42)
    assert Error(3, 42).code_name == "code_42" and Error(3, 6).code_name == "unsupported"
    assert Error(3, 6).code is ErrorCode.UNSUPPORTED
    identity = unpack(0x81, bytes([1, 1, 0, 0, 2, 0xC7, 235, 0, 3]) + b"new")
    assert int(identity.caps) == 0xC7 and Caps.TILT not in identity.caps


def test_pulse_helper():
    assert SetPattern.pulse(0, 50, 200, 100) == SetPattern(0, PatternMode.PULSE, 100, 0, 50_000, 200_000)
    p = SetPattern.pulse(1, 0.0125, 2.5, 49.5, carrier_hz=234.5)
    assert (p.on_us, p.off_us, p.intensity, p.carrier_hz) == (13, 2500, 50, 235)  # round half up
    assert (p.on_ms, p.off_ms) == (0.013, 2.5)


def test_continuous_texture_and_off_helpers():
    assert SetPattern.continuous(0, 75) == SetPattern(0, PatternMode.CONTINUOUS, 75, 0, 0, 0)
    t = SetPattern.texture(0, 2000, 0.5, 100)
    assert (t.mode, t.carrier_hz, t.on_us, t.off_us, t.period_us) == (PatternMode.TEXTURE, 0, 1000, 1000, 2000)
    t = SetPattern.texture(0, 3333.4, 0.3, 100)
    assert (t.on_us, t.off_us) == (1000, 2333)  # the period is kept exactly: on + off = round(P)
    assert SetPattern.off(2) == SetPattern(2, 0, 0, 0, 0, 0)
    assert SetPattern.off().channel == ALL_CHANNELS


@pytest.mark.parametrize("degrees, cdeg", [(90, 9000), (-90, 27000), (450, 9000), (359.996, 0), (-0.0, 0),
                                           (0.004, 0), (0.005, 1), (180.125, 18013)])
def test_tilt_from_degrees_normalises(degrees, cdeg):
    tilt = SetTilt.from_degrees(0, degrees, 100)
    assert tilt.direction_cdeg == cdeg
    assert 0 <= tilt.direction_deg < 360


def test_temperature_and_friction_units():
    assert SetTemperature.from_celsius(0, 32.5) == SetTemperature(0, 3250)
    assert SetTemperature(0, 3250).celsius == 32.5
    assert SetFriction.from_coefficient(0, 0.5) == SetFriction(0, 500)
    assert SetFriction(0, 125).coefficient == 0.125


def test_layer_keys():
    assert SetPattern.off(1).layer_key == (1, "pattern")
    assert SetTilt.flat(0).layer_key == (0, "tilt")
    assert SetTemperature(0xFF, 0).layer_key == (0xFF, "temperature")
    assert SetFriction(0, 0).layer_key == (0, "friction")
    assert Stop(1).layer_key == (1, "stop")


def test_overrides_and_touches():
    assert overrides((0, "pattern"), (0, "pattern"))
    assert overrides((0xFF, "pattern"), (1, "pattern"))
    assert not overrides((1, "pattern"), (0xFF, "pattern"))
    assert overrides((0, "stop"), (0, "tilt")) and overrides((0xFF, "stop"), (1, "stop"))
    assert not overrides((0, "tilt"), (0, "stop"))        # tilt leaves the rest of a STOP in place
    assert not overrides((0, "stop"), (0xFF, "stop"))     # channel 1 stays stopped by the older one
    assert touches((0, "tilt"), (0xFF, "stop")) and touches((1, "pattern"), (0xFF, "pattern"))
    assert not touches((0, "tilt"), (1, "stop")) and not touches((0, "tilt"), (0, "pattern"))


def test_what_a_stop_leaves_on_each_layer():
    assert as_seen_by(Stop(0xFF), (1, "pattern")) == SetPattern.off(1)
    assert as_seen_by(Stop(1), (1, "tilt")) == SetTilt.flat(1)
    assert as_seen_by(Stop(1), (1, "stop")) == Stop(1)
    # "temperature and friction layers off" has no SET value (0 would mean 0 °C)
    assert as_seen_by(Stop(1), (1, "temperature")) is None
    assert as_seen_by(SetTilt(0xFF, 100, 5), (0, "tilt")) == SetTilt(0, 100, 5)


channels = st.sampled_from([0, 1, 0xFF])
set_messages = st.one_of(
    st.builds(SetPattern, channels, st.integers(0, 3), st.integers(0, 100), st.integers(0, 0xFFFF),
              st.integers(0, m.MAX_ON_OFF_US), st.integers(0, m.MAX_ON_OFF_US)),
    st.builds(SetTilt, channels, st.integers(0, 35_999), st.integers(0, 100)),
    st.builds(SetTemperature, channels, st.integers(0, 5000)),
    st.builds(SetFriction, channels, st.integers(0, 5000)),
    st.builds(Stop, channels),
    st.builds(Identify, st.integers(0, 255), st.integers(0, 255), st.integers(0, 255), st.integers(0, 255),
              st.integers(1, 254), st.integers(0, 255), st.integers(0, 0xFFFF),
              st.text("abcdefghijklmnopqrstuvwxyz0123456789-_", min_size=1, max_size=32)),
    st.builds(m.Ping, st.integers(0, 2 ** 32 - 1)),
    st.builds(Error, st.integers(0, 255), st.integers(0, 255)),
)


@given(set_messages)
def test_every_message_round_trips_and_fits_a_frame(message):
    payload = message.pack()
    assert len(payload) <= 58
    assert unpack(type(message).TYPE, payload) == message


@given(st.integers(0, 255), st.binary(max_size=70))
def test_unpack_raises_only_message_errors(type_, payload):
    try:
        unpack(type_, payload)
    except MessageError as exc:
        assert exc.kind in ("unknown_type", "bad_length", "bad_value")
