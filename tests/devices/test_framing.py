"""Framing (docs/device-protocol.md §1): known answers, the shared vectors, and a decoder that
resynchronises after anything and never raises."""

import binascii
import json
from pathlib import Path

import pytest
from cobs import cobs
from hypothesis import given
from hypothesis import strategies as st

from devices import messages
from devices.framing import MAX_PAYLOAD, Frame, FrameDecoder, FrameError, crc16, decode_frame, encode_frame

VECTORS = json.loads((Path(__file__).parents[1] / "vectors" / "device_frames.json").read_text())


# ---- known answers, written out by hand (not produced by our encoder) -------------------------

def test_crc_check_value():
    assert crc16(b"123456789") == 0x29B1 == binascii.crc_hqx(b"123456789", 0xFFFF)  # §1 check value
    assert crc16(b"") == 0xFFFF  # init value, no final XOR
    assert crc16(b"A") == 0xB915  # CRC-16/CCITT-FALSE catalogue value


@pytest.mark.parametrize("raw, encoded", [
    ("00", "0101"),
    ("0000", "010101"),
    ("001100", "01021101"),
    ("11220033", "0311220233"),
    ("11223344", "0511223344"),
    ("11000000", "0211010101"),
])
def test_cobs_wikipedia_examples(raw, encoded):
    assert cobs.encode(bytes.fromhex(raw)).hex() == encoded
    assert cobs.decode(bytes.fromhex(encoded)).hex() == raw


def test_cobs_254_byte_run_has_no_trailing_code():
    run = bytes(range(1, 255))
    assert cobs.encode(run) == b"\xff" + run
    assert cobs.encode(run + b"\x01") == b"\xff" + run + b"\x02\x01"


def test_the_doc_example_frame():
    # §7: set_tilt_right, type 17, seq 3, payload 00 28 23 64; CRC computed by hand-checked crc_hqx
    body = bytes([0x11, 0x03, 0x00, 0x28, 0x23, 0x64])
    crc = binascii.crc_hqx(body, 0xFFFF)
    expected = bytes([0x03, 0x11, 0x03, 0x06, 0x28, 0x23, 0x64, crc & 0xFF, crc >> 8, 0x00])
    assert crc & 0xFF and crc >> 8  # no zero in the CRC, so the COBS above is complete
    assert encode_frame(0x11, 3, bytes.fromhex("00282364")) == expected


# ---- shared vectors ---------------------------------------------------------------------------

@pytest.mark.parametrize("v", VECTORS["crc16"], ids=lambda v: v["data_hex"][:16] or "empty")
def test_crc_vectors(v):
    assert crc16(bytes.fromhex(v["data_hex"])) == v["crc"]


@pytest.mark.parametrize("v", VECTORS["cobs"], ids=lambda v: v["raw_hex"][:16] or "empty")
def test_cobs_vectors(v):
    assert cobs.encode(bytes.fromhex(v["raw_hex"])).hex() == v["encoded_hex"]
    assert cobs.decode(bytes.fromhex(v["encoded_hex"])).hex() == v["raw_hex"]


@pytest.mark.parametrize("v", VECTORS["frames"], ids=lambda v: v["name"])
def test_frame_vectors_encode_and_decode(v):
    payload = bytes.fromhex(v["payload_hex"])
    wire = bytes.fromhex(v["frame_hex"])
    assert encode_frame(v["type"], v["seq"], payload) == wire
    assert FrameDecoder().feed(wire) == [Frame(v["type"], v["seq"], payload)]
    assert len(wire) <= 64


def classify(wire: bytes) -> str:
    """What a receiver makes of one wire frame: a §1 error kind, a message-level kind, or "ok"."""
    items = FrameDecoder().feed(wire)
    assert len(items) == 1, items
    if isinstance(items[0], FrameError):
        return items[0].kind
    try:
        messages.unpack(items[0].type, items[0].payload)
    except messages.MessageError as exc:
        return exc.kind
    return "ok"


@pytest.mark.parametrize("v", VECTORS["invalid"], ids=lambda v: v["name"])
def test_invalid_vectors_are_rejected_with_their_error(v):
    assert classify(bytes.fromhex(v["bytes_hex"])) == v["error"]


def test_the_vectors_cover_every_message_type_and_error():
    types = {v["type"] for v in VECTORS["frames"]}
    assert types == set(messages.MESSAGE_TYPES)
    errors = {v["error"] for v in VECTORS["invalid"]}
    assert {"framing", "too_long", "bad_length", "bad_crc", "unknown_type", "bad_value"} <= errors


# ---- decoder behaviour --------------------------------------------------------------------------

TILT = encode_frame(0x11, 3, bytes.fromhex("00282364"))


def test_empty_frames_are_flushes_not_errors():
    assert FrameDecoder().feed(b"\x00\x00" + TILT + b"\x00") == [Frame(0x11, 3, bytes.fromhex("00282364"))]


def test_byte_by_byte_equals_all_at_once():
    stream = b"\x00" + TILT + b"\x07\x07\x00" + TILT + TILT
    whole = FrameDecoder().feed(stream)
    decoder = FrameDecoder()
    single = [item for i in range(len(stream)) for item in decoder.feed(stream[i:i + 1])]
    assert whole == single
    assert [type(x) for x in whole] == [Frame, FrameError, Frame, Frame]


def test_too_long_is_reported_once_and_the_decoder_resynchronises():
    decoder = FrameDecoder()
    items = decoder.feed(b"\x55" * 200)
    assert [x.kind for x in items] == ["too_long"]
    assert decoder.feed(b"\x55" * 100) == []  # still discarding up to the next 0x00
    assert decoder.feed(b"\x00" + TILT) == [Frame(0x11, 3, bytes.fromhex("00282364"))]


def test_size_limits_follow_the_table():
    # "more than 64 bytes before a delimiter" is too_long; 64 bytes decode to 63 > 62: bad_length
    assert [x.kind for x in FrameDecoder().feed(b"\x55" * 65 + b"\x00")] == ["too_long"]
    assert [x.kind for x in FrameDecoder().feed(b"\x40" + b"\x55" * 63 + b"\x00")] == ["bad_length"]


def test_truncated_and_corrupt_frames():
    assert decode_frame(TILT[:-3]).kind == "framing"  # last code byte points past the end
    assert decode_frame(b"\x02\x11").kind == "bad_length"  # decodes to one byte
    bad = bytearray(TILT)
    bad[4] ^= 0x01
    assert decode_frame(bytes(bad[:-1])).kind == "bad_crc"


def test_encode_refuses_what_the_protocol_cannot_carry():
    with pytest.raises(ValueError):
        encode_frame(0x10, 0, bytes(MAX_PAYLOAD + 1))
    with pytest.raises(ValueError):
        encode_frame(256, 0)
    with pytest.raises(ValueError):
        encode_frame(0x10, -1)
    assert len(encode_frame(0x10, 0, bytes(MAX_PAYLOAD))) <= 64


@given(st.integers(0, 255), st.integers(0, 255), st.binary(max_size=MAX_PAYLOAD))
def test_round_trip(type_, seq, payload):
    wire = encode_frame(type_, seq, payload)
    assert wire[-1] == 0 and 0 not in wire[:-1] and len(wire) <= 64
    assert FrameDecoder().feed(wire) == [Frame(type_, seq, payload)]


@given(st.lists(st.binary(max_size=200), max_size=8))
def test_arbitrary_bytes_never_raise(chunks):
    decoder = FrameDecoder()
    for chunk in chunks:
        for item in decoder.feed(chunk):
            assert isinstance(item, (Frame, FrameError))


@given(st.binary(max_size=300), st.integers(0, 255), st.binary(max_size=MAX_PAYLOAD))
def test_a_good_frame_after_garbage_is_still_decoded(garbage, seq, payload):
    decoder = FrameDecoder()
    decoder.feed(garbage)
    items = decoder.feed(b"\x00" + encode_frame(0x83, seq, payload))
    assert items[-1] == Frame(0x83, seq, payload)
