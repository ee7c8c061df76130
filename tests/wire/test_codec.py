"""The Python codec against the shared vectors (tests/vectors/), and its refusals."""

import json
import math
from pathlib import Path

import msgpack
import pytest

from server.wire import codec
from server.wire.codec import WireError, decode, encode
from server.wire.messages import Actuators, Answer, Hello, Input, Tracker, parse_client_message

VECTORS = Path(__file__).parents[1] / "vectors"
MESSAGES = json.loads((VECTORS / "messages.json").read_text())["vectors"]
INVALID = json.loads((VECTORS / "invalid.json").read_text())["frames"]
COORDS = json.loads((VECTORS / "coordinates.json").read_text())


def _floaty(value):
    """The same message as a server would build it: every number a Python float."""
    if isinstance(value, bool):
        return value
    if isinstance(value, (int, float)):
        return float(value)
    if isinstance(value, dict):
        return {k: _floaty(v) if k not in ("type",) else v for k, v in value.items()}
    if isinstance(value, list):
        return [_floaty(v) for v in value]
    return value


@pytest.mark.parametrize("vector", MESSAGES, ids=lambda v: v["name"])
def test_encoder_reproduces_vector_bytes_even_from_floats(vector):
    expected = bytes.fromhex(vector["msgpack_hex"])
    assert encode(vector["message"]) == expected
    # Integral floats must be canonicalised to ints, as JS encoders write them.
    assert encode(_floaty(vector["message"])) == expected


@pytest.mark.parametrize("vector", MESSAGES, ids=lambda v: v["name"])
def test_decoder_reads_vector(vector):
    assert decode(bytes.fromhex(vector["msgpack_hex"])) == vector["message"]
    text = encode(vector["message"], "json")
    assert json.loads(text) == vector["message"]
    assert decode(text, "json") == vector["message"]


@pytest.mark.parametrize("vector", [v for v in MESSAGES if v["direction"] == "client_to_server"],
                         ids=lambda v: v["name"])
def test_client_messages_parse_and_round_trip(vector):
    parsed = parse_client_message(decode(bytes.fromhex(vector["msgpack_hex"])))
    assert isinstance(parsed, (Hello, Tracker, Input, Answer, Actuators))
    assert encode(parsed.to_wire()).hex() == vector["msgpack_hex"]


@pytest.mark.parametrize("frame", INVALID, ids=lambda f: f["name"])
def test_invalid_frames_are_refused_with_their_code(frame):
    with pytest.raises(WireError) as info:
        parse_client_message(decode(bytes.fromhex(frame["msgpack_hex"])))
    assert info.value.code == frame["code"]
    assert info.value.message  # a sentence for a person


def test_size_limit_and_format_mismatch():
    big = msgpack.packb({"type": "input", "key": "a", "action": "down", "pad": "x" * codec.MAX_FRAME_BYTES})
    with pytest.raises(WireError) as info:
        decode(big)
    assert info.value.code == "too_large"
    with pytest.raises(WireError) as info:
        decode('{"type":"input"}', "msgpack")
    assert info.value.code == "bad_encoding"
    with pytest.raises(WireError) as info:
        decode(b"\x80", "json")
    assert info.value.code == "bad_encoding"


@pytest.mark.parametrize("text", ['{"type":"tracker","seq":1,"t":0,"pos":[NaN,0,0]}',
                                  '{"type":"tracker","seq":1,"t":Infinity,"pos":[0,0,0]}'])
def test_json_non_finite_refused(text):
    with pytest.raises(WireError) as info:
        parse_client_message(decode(text, "json"))
    assert info.value.code == "non_finite"


def test_encoder_refuses_non_finite_and_keeps_big_floats():
    with pytest.raises(WireError):
        encode({"type": "state", "t": math.nan})
    assert decode(encode({"type": "x", "n": 1e300}))["n"] == 1e300
    assert decode(encode({"type": "x", "n": 2.0**60}))["n"] == 2.0**60


def _rotate(q, p):
    w, x, y, z = q
    px, py, pz = p
    # p' = q p q*, expanded (Hamilton convention, as three.js and Unity compute it).
    tx = 2 * (y * pz - z * py)
    ty = 2 * (z * px - x * pz)
    tz = 2 * (x * py - y * px)
    return (px + w * tx + (y * tz - z * ty), py + w * ty + (z * tx - x * tz), pz + w * tz + (x * ty - y * tx))


def test_coordinate_vectors_are_consistent_rotations():
    """Converting then rotating equals rotating then converting, for three.js and Unity."""
    def to_three(p):
        return (p[1], p[2], p[0])

    def to_unity(p):
        return (p[1], p[2], -p[0])
    for point in COORDS["points"]:
        assert list(to_three(point["scene"])) == point["three"]
        assert list(to_unity(point["scene"])) == point["unity"]
    probe = (0.3, -0.7, 0.2)
    for rot in COORDS["rotations"]:
        q = rot["scene"]
        expected_three = to_three(_rotate(q, probe))
        got_three = _rotate(rot["three"], to_three(probe))
        assert got_three == pytest.approx(expected_three, abs=1e-12)
        ux, uy, uz, uw = rot["unity_xyzw"]
        got_unity = _rotate((uw, ux, uy, uz), to_unity(probe))
        assert got_unity == pytest.approx(to_unity(_rotate(q, probe)), abs=1e-12)
