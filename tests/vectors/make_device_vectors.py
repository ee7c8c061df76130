"""Writes tests/vectors/device_frames.json, the shared vectors of docs/device-protocol.md §7
(run once; the output is checked in, and running it again must give identical bytes).

Built without devices/ on purpose: the CRC is computed bit by bit, COBS is written out from
Cheshire & Baker's description and the payloads are packed from the field tables of §2–§3 here,
so the vectors check the Python codec (and the C core in devices/firmware) instead of restating
them. `fields` use the payload field names of §2 and §3 (IDENTIFY includes model_len).
"""

import json
import struct
from pathlib import Path

HERE = Path(__file__).parent


def crc16_ccitt_false(data: bytes) -> int:
    crc = 0xFFFF
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else crc << 1
            crc &= 0xFFFF
    return crc


def cobs_encode(data: bytes) -> bytes:
    """Minimal COBS: a block ends at a zero (implied) or after 254 data bytes when more input
    follows (code 0xFF, no implied zero)."""
    out, block = bytearray(), bytearray()
    for i, byte in enumerate(data):
        if byte == 0:
            out += bytes([len(block) + 1]) + block
            block.clear()
        else:
            block.append(byte)
            if len(block) == 254 and i + 1 < len(data):
                out += b"\xff" + block
                block.clear()
    return bytes(out + bytes([len(block) + 1]) + block)


def cobs_decode(data: bytes) -> bytes:
    out, i = bytearray(), 0
    while i < len(data):
        code = data[i]
        if code == 0 or i + code > len(data) or 0 in data[i + 1:i + code]:
            raise ValueError("not COBS")
        out += data[i + 1:i + code]
        i += code
        if code != 0xFF and i < len(data):
            out.append(0)
    return bytes(out)


def wire(raw: bytes) -> bytes:
    """Wire form of an already CRC-ed frame: COBS + delimiter."""
    return cobs_encode(raw) + b"\x00"


def with_crc(body: bytes) -> bytes:
    return body + crc16_ccitt_false(body).to_bytes(2, "little")


# payload layouts of §2 and §3: (type, [(field, struct code)])
LAYOUTS = {
    "HELLO": (0x01, [("version", "B")]),
    "PING": (0x02, [("token", "I")]),
    "SET_WATCHDOG": (0x03, [("timeout_ms", "H")]),
    "SET_PATTERN": (0x10, [("channel", "B"), ("mode", "B"), ("intensity", "B"), ("carrier_hz", "H"),
                           ("on_us", "I"), ("off_us", "I")]),
    "SET_TILT": (0x11, [("channel", "B"), ("direction_cdeg", "H"), ("magnitude", "B")]),
    "SET_TEMPERATURE": (0x12, [("channel", "B"), ("centi_celsius", "h")]),
    "SET_FRICTION": (0x13, [("channel", "B"), ("milli", "H")]),
    "STOP": (0x1F, [("channel", "B")]),
    "IDENTIFY": (0x81, [("version", "B"), ("fw_major", "B"), ("fw_minor", "B"), ("fw_patch", "B"),
                        ("channels", "B"), ("caps", "B"), ("carrier_hz", "H"), ("model_len", "B")]),
    "PONG": (0x82, [("token", "I")]),
    "ACK": (0x83, [("ref_seq", "B")]),
    "ERROR": (0x84, [("ref_seq", "B"), ("code", "B")]),
    "WATCHDOG": (0x85, [("timeout_ms", "H"), ("trips", "H")]),
}


def payload(name: str, fields: dict) -> bytes:
    _, layout = LAYOUTS[name]
    data = struct.pack("<" + "".join(code for _, code in layout), *(fields[f] for f, _ in layout))
    return data + fields["model"].encode("ascii") if name == "IDENTIFY" else data


def identify(version, fw, channels, caps, carrier_hz, model):
    return {"version": version, "fw_major": fw[0], "fw_minor": fw[1], "fw_patch": fw[2], "channels": channels,
            "caps": caps, "carrier_hz": carrier_hz, "model_len": len(model), "model": model}


def pattern(channel, mode, intensity, carrier_hz, on_us, off_us):
    return {"channel": channel, "mode": mode, "intensity": intensity, "carrier_hz": carrier_hz,
            "on_us": on_us, "off_us": off_us}


# (name, direction = sender, message, seq, fields)
FRAMES = [
    ("hello_v1", "host", "HELLO", 0, {"version": 1}),
    ("ping", "host", "PING", 1, {"token": 0x12345678}),
    ("set_pattern_pulse_50_200ms", "host", "SET_PATTERN", 2, pattern(0, 1, 100, 0, 50_000, 200_000)),
    ("set_tilt_right", "host", "SET_TILT", 3, {"channel": 0, "direction_cdeg": 9000, "magnitude": 100}),
    ("set_pattern_pulse_carrier_235hz", "host", "SET_PATTERN", 4, pattern(1, 1, 60, 235, 20_000, 80_000)),
    ("set_pattern_continuous", "host", "SET_PATTERN", 5, pattern(1, 2, 75, 0, 0, 0)),
    ("set_pattern_texture_2000us", "host", "SET_PATTERN", 6, pattern(0, 3, 100, 0, 1000, 1000)),
    ("set_pattern_off_all_channels", "host", "SET_PATTERN", 7, pattern(0xFF, 0, 0, 0, 0, 0)),
    ("set_pattern_max_times", "host", "SET_PATTERN", 8, pattern(0, 1, 100, 65535, 60_000_000, 60_000_000)),
    ("set_tilt_left_half", "host", "SET_TILT", 9, {"channel": 0, "direction_cdeg": 27000, "magnitude": 50}),
    ("set_tilt_flat", "host", "SET_TILT", 10, {"channel": 0, "direction_cdeg": 0, "magnitude": 0}),
    ("set_tilt_max_direction", "host", "SET_TILT", 11, {"channel": 0, "direction_cdeg": 35999, "magnitude": 1}),
    ("set_temperature_32_5c", "host", "SET_TEMPERATURE", 12, {"channel": 0, "centi_celsius": 3250}),
    ("set_friction_0_5", "host", "SET_FRICTION", 13, {"channel": 0, "milli": 500}),
    ("stop_all_channels", "host", "STOP", 14, {"channel": 0xFF}),
    ("stop_channel_1", "host", "STOP", 255, {"channel": 1}),
    ("identify_fingertac", "device", "IDENTIFY", 0, identify(1, (1, 0, 0), 2, 0x07, 235, "fingertac")),
    ("identify_ferrovibe", "device", "IDENTIFY", 1, identify(1, (1, 0, 0), 1, 0x0F, 235, "ferrovibe")),
    ("pong", "device", "PONG", 2, {"token": 0x12345678}),
    ("ack_set_tilt", "device", "ACK", 3, {"ref_seq": 3}),
    ("error_bad_value", "device", "ERROR", 4, {"ref_seq": 9, "code": 5}),
    ("error_unsupported", "device", "ERROR", 5, {"ref_seq": 3, "code": 6}),
    ("error_bad_crc", "device", "ERROR", 6, {"ref_seq": 0xFF, "code": 1}),
    ("error_bad_version", "device", "ERROR", 7, {"ref_seq": 0, "code": 8}),
    ("set_watchdog_100ms", "host", "SET_WATCHDOG", 15, {"timeout_ms": 100}),
    ("set_watchdog_off", "host", "SET_WATCHDOG", 16, {"timeout_ms": 0}),
    ("watchdog_tripped", "device", "WATCHDOG", 8, {"timeout_ms": 100, "trips": 1}),
]


def frame_raw(name: str, seq: int, fields: dict) -> bytes:
    return with_crc(bytes([LAYOUTS[name][0], seq]) + payload(name, fields))


TILT_RIGHT = frame_raw("SET_TILT", 3, {"channel": 0, "direction_cdeg": 9000, "magnitude": 100})


def flip(data: bytes, index: int, bit: int = 0) -> bytes:
    out = bytearray(data)
    out[index] ^= 1 << bit
    return bytes(out)


# Each is one complete wire frame a receiver must reject with the named error (§1 table, and
# §3 bad_value for a host→device command out of range). Only host→device types are used for
# bad_length / bad_value, so every receiver (device or host) classifies them alike.
INVALID = [
    ("flipped_crc_bit", wire(flip(TILT_RIGHT, len(TILT_RIGHT) - 1, 3)), "bad_crc"),
    ("flipped_payload_bit", wire(flip(TILT_RIGHT, 3, 0)), "bad_crc"),
    ("truncated_frame", wire(TILT_RIGHT)[:-4] + b"\x00", "framing"),
    ("cobs_code_past_end", bytes([0x09, 0x11, 0x03, 0x28, 0x00]), "framing"),
    ("decoded_too_short", wire(bytes([0x83, 0x01, 0x2A])), "bad_length"),
    ("unknown_type", wire(with_crc(bytes([0x7E, 0x05, 0x01]))), "unknown_type"),
    ("set_tilt_payload_too_short", wire(with_crc(bytes([0x11, 0x06, 0x00, 0x28, 0x23]))), "bad_length"),
    ("stop_payload_too_long", wire(with_crc(bytes([0x1F, 0x07, 0xFF, 0x00]))), "bad_length"),
    ("garbage_run_too_long", bytes([0x55]) * 80 + b"\x00", "too_long"),
    ("set_pattern_intensity_101", wire(frame_raw("SET_PATTERN", 8, pattern(0, 1, 101, 0, 50_000, 200_000))),
     "bad_value"),
    ("set_pattern_unknown_mode", wire(frame_raw("SET_PATTERN", 9, pattern(0, 4, 50, 0, 1000, 1000))), "bad_value"),
    ("set_pattern_on_us_too_long", wire(frame_raw("SET_PATTERN", 10, pattern(0, 1, 50, 0, 60_000_001, 0))),
     "bad_value"),
    ("set_tilt_direction_36000", wire(frame_raw("SET_TILT", 11, {"channel": 0, "direction_cdeg": 36000,
                                                                "magnitude": 50})), "bad_value"),
    ("set_temperature_negative", wire(frame_raw("SET_TEMPERATURE", 12, {"channel": 0, "centi_celsius": -100})),
     "bad_value"),
    ("set_friction_5001", wire(frame_raw("SET_FRICTION", 13, {"channel": 0, "milli": 5001})), "bad_value"),
    ("set_watchdog_9ms", wire(frame_raw("SET_WATCHDOG", 14, {"timeout_ms": 9})), "bad_value"),
]

COBS = [
    ("", "01"),
    ("00", "0101"),
    ("0000", "010101"),
    ("001100", "01021101"),
    ("11220033", "0311220233"),
    ("11223344", "0511223344"),
    ("11000000", "0211010101"),
    (bytes(range(1, 255)).hex(), "ff" + bytes(range(1, 255)).hex()),                   # 254 non-zero bytes
    ("00" + bytes(range(1, 255)).hex(), "01ff" + bytes(range(1, 255)).hex()),
    (bytes(range(1, 256)).hex(), "ff" + bytes(range(1, 255)).hex() + "02ff"),
    (bytes(range(2, 256)).hex() + "00", "ff" + bytes(range(2, 256)).hex() + "0101"),
]

CRC = [b"123456789", b"", b"A", bytes([0x11, 0x03, 0x00, 0x28, 0x23, 0x64]), bytes(range(256))]


def frame_check(data: bytes) -> str | None:
    """§1 as a receiver applies it to one wire frame; None if the frame itself is good."""
    encoded = data[:-1]
    if len(encoded) > 64:
        return "too_long"
    try:
        raw = cobs_decode(encoded)
    except ValueError:
        return "framing"
    if not 4 <= len(raw) <= 62:
        return "bad_length"
    return None if crc16_ccitt_false(raw[:-2]) == int.from_bytes(raw[-2:], "little") else "bad_crc"


def main() -> None:
    for raw_hex, enc_hex in COBS:  # the hand-written answers (Wikipedia's COBS examples) hold
        assert cobs_encode(bytes.fromhex(raw_hex)).hex() == enc_hex, raw_hex
        assert cobs_decode(bytes.fromhex(enc_hex)).hex() == raw_hex, enc_hex
    assert crc16_ccitt_false(b"123456789") == 0x29B1  # §1 check value
    frames = []
    for name, direction, kind, seq, fields in FRAMES:
        data = payload(kind, fields)
        assert len(data) <= 58
        frames.append({"name": name, "direction": direction, "type": LAYOUTS[kind][0], "seq": seq,
                       "payload_hex": data.hex(), "fields": fields,
                       "frame_hex": wire(frame_raw(kind, seq, fields)).hex()})
    for name, data, error in INVALID:
        assert data.endswith(b"\x00") and 0 not in data[:-1], name
        expected = error if error in ("framing", "too_long", "bad_crc") or name == "decoded_too_short" else None
        assert frame_check(data) == expected, (name, frame_check(data))
    doc = {
        "version": 1,
        "note": "docs/device-protocol.md §7; written by tests/vectors/make_device_vectors.py",
        "crc16": [{"data_hex": d.hex(), "crc": crc16_ccitt_false(d)} for d in CRC],
        "cobs": [{"raw_hex": r, "encoded_hex": e} for r, e in COBS],
        "frames": frames,
        "invalid": [{"name": n, "bytes_hex": b.hex(), "error": e} for n, b, e in INVALID],
    }
    (HERE / "device_frames.json").write_text(json.dumps(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
