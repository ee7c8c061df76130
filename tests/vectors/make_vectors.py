"""Writes the shared wire-protocol test vectors (run once; the output is committed).

The bytes are produced with the msgpack library directly from hand-written canonical maps
(integral numbers already as ints, fields in documented order), not with server/wire, so the
vectors check the codec instead of restating it. Every client codec (Python, JS, C#) must
reproduce the bytes of the messages it sends and decode every vector to its message.
"""

import json
import math
import struct
from pathlib import Path

import msgpack

HERE = Path(__file__).parent

MESSAGES = [
    ("hello-participant", "client_to_server",
     {"type": "hello", "v": 1, "role": "participant", "client": "viestac-web/0.1"}),
    ("hello-observer", "client_to_server",
     {"type": "hello", "v": 1, "role": "observer", "client": ""}),
    ("tracker-position", "client_to_server",
     {"type": "tracker", "seq": 42, "t": 1234.5, "pos": [0.125, -0.6, 0.3]}),
    ("tracker-integral-coordinates", "client_to_server",
     {"type": "tracker", "seq": 0, "t": 0, "pos": [0, 1, -2]}),
    ("tracker-with-orientation", "client_to_server",
     {"type": "tracker", "seq": 70000, "t": 98765.25, "pos": [0.01, 0.02, 0.03],
      "quat": [0.7071067811865476, 0, 0.7071067811865476, 0]}),
    ("input-key-down", "client_to_server", {"type": "input", "key": "ArrowUp", "action": "down"}),
    ("input-space-press", "client_to_server", {"type": "input", "key": " ", "action": "press"}),
    ("input-command-value", "client_to_server",
     {"type": "input", "key": "tap_angle", "action": "press", "value": -30}),
    ("welcome", "server_to_client",
     {"type": "welcome", "v": 1, "client_id": 7, "role": "participant", "server": "viestac/0.1.0",
      "tick_hz": 1000, "state_hz": 60, "format": "msgpack"}),
    ("scene-minimal", "server_to_client",
     {"type": "scene", "v": 1, "hash": "0123abcd", "scene": {
         "name": "demo",
         "camera": {"projection": "orthographic", "position": [5, 0, 0.35], "target": [0, 0, 0.35],
                    "up": [0, 0, 1], "height": 1.6},
         "hip": {"radius": 0.06, "proxy_radius": 0.06, "color": "#ffd400"},
         "objects": [{"id": "dome", "shape": {"type": "hemisphere", "radius": 0.6},
                      "pose": {"pos": [0, 0, 0], "quat": [1, 0, 0, 0]},
                      "material": {"color": "#3a7bd5", "opacity": 1, "stiffness_n_per_m": 1000,
                                   "static_friction": 0, "dynamic_friction": 0},
                      "haptic": True, "visible": True}],
         "hud": {"text": "touch the dome"}}}),
    ("state-in-contact", "server_to_client",
     {"type": "state", "frame": 1201, "tick": 20016, "t": 20.016, "scene": "0123abcd",
      "hip": [0, -0.2, 0.55], "proxy": [0, -0.2012, 0.5644], "force": [0, -1.2, 14.4],
      "contact": True, "contacts": [["dome", [0, -0.3354, 0.9421], 0.0153]],
      "objects": [], "cues": [{"kind": "tilt", "direction_deg": 20.5, "magnitude_pct": 100}],
      "hud": "", "values": {"angle_deg": -20.5},
      "telemetry": {"period_p50_us": 1000, "period_p99_us": 1026.5, "period_max_us": 1180,
                    "overruns": 0, "tick_cost_p99_us": 31.2, "ticks": 20016, "rt": True},
      "visible": {"angle_scale": False},
      "events": [{"tick": 20010, "t": 20.01, "name": "tap", "angle_deg": -20.5}]}),
    ("scene-overlays-skin", "server_to_client",
     {"type": "scene", "v": 1, "hash": "4567cdef", "scene": {
         "name": "demo-aids",
         "camera": {"projection": "orthographic", "position": [5, 0, 0.35], "target": [0, 0, 0.35],
                    "up": [0, 0, 1], "height": 1.6},
         "hip": {"radius": 0.06, "proxy_radius": 0.06, "color": "#ffd400"},
         "objects": [{"id": "ground", "shape": {"type": "plane", "size": [3, 3]},
                      "pose": {"pos": [0, 0, 0], "quat": [1, 0, 0, 0]},
                      "material": {"color": "#8c8c8c", "opacity": 1, "stiffness_n_per_m": 1000,
                                   "static_friction": 0, "dynamic_friction": 0,
                                   "skin": {"image": "/skins/cork.svg", "tile": [0.5, 0.5]}},
                      "haptic": True, "visible": True}],
         "hud": {"text": ""},
         "overlays": [{"id": "angle_scale", "kind": "angle_scale", "centre": [0, 0, 0], "radius": 0.66,
                       "from_deg": -90, "to_deg": 90, "minor_deg": 10, "major_deg": 30, "color": "#1b1b1b",
                       "visible": True},
                      {"id": "left_label", "kind": "label", "pos": [0, -1, 1], "text": "1 (softest)",
                       "size": 0.12, "color": "#1b1b1b", "visible": True}]}}),
    ("error-bad-message", "server_to_client",
     {"type": "error", "code": "bad_message", "message": "'pos' must be an array of 3 numbers"}),
]

# Frames the server must refuse, with the error code it must answer (connection stays open).
NAN = struct.pack(">Bd", 0xCB, math.nan)
INF = struct.pack(">Bd", 0xCB, math.inf)


def tracker_with(pos_bytes: bytes) -> bytes:
    head = msgpack.packb({"type": "tracker", "seq": 1, "t": 0})[1:]  # drop the fixmap header
    return bytes([0x84]) + head + msgpack.packb("pos") + bytes([0x93]) + pos_bytes


INVALID = [
    ("not-msgpack", bytes([0xC1, 0x00, 0x01]), "bad_encoding"),
    ("truncated-map", bytes([0x82, 0xA4]) + b"ty", "bad_encoding"),
    ("array-not-map", msgpack.packb([1, 2, 3]), "bad_message"),
    ("no-type", msgpack.packb({"seq": 1}), "bad_message"),
    ("type-not-string", msgpack.packb({"type": 5}), "bad_message"),
    ("unknown-type", msgpack.packb({"type": "teleport", "pos": [0, 0, 0]}), "unknown_type"),
    ("tracker-nan", tracker_with(NAN + msgpack.packb(0) + msgpack.packb(0)), "non_finite"),
    ("tracker-inf", tracker_with(msgpack.packb(0) + INF + msgpack.packb(0)), "non_finite"),
    ("tracker-pos-string", msgpack.packb({"type": "tracker", "seq": 1, "t": 0, "pos": "0,0,0"}), "bad_message"),
    ("tracker-pos-two", msgpack.packb({"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0]}), "bad_message"),
    ("tracker-seq-negative", msgpack.packb({"type": "tracker", "seq": -1, "t": 0, "pos": [0, 0, 0]}), "bad_message"),
    ("tracker-pos-bool", msgpack.packb({"type": "tracker", "seq": 1, "t": 0, "pos": [True, 0, 0]}), "bad_message"),
    ("input-bad-action", msgpack.packb({"type": "input", "key": "a", "action": "hold"}), "bad_message"),
    ("input-value-map", msgpack.packb({"type": "input", "key": "tap_angle", "action": "press", "value": {"a": 1}}),
     "bad_message"),
    ("hello-bad-role", msgpack.packb({"type": "hello", "v": 1, "role": "admin", "client": ""}), "bad_message"),
]


def three(p):
    x, y, z = p
    return [y, z, x]


def unity(p):
    x, y, z = p
    return [y, z, -x]


def quat_three(q):
    w, x, y, z = q
    return [w, y, z, x]


def quat_unity_xyzw(q):
    w, x, y, z = q
    return [-y, -z, x, w]


POINTS = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0.5, -0.6, 0.3], [-2, 3.25, -0.125]]
H = math.sqrt(0.5)
ROTATIONS = [[1, 0, 0, 0], [H, 0, 0, H], [H, H, 0, 0], [H, 0, H, 0], [0.5, 0.5, 0.5, 0.5]]


def main() -> None:
    vectors = [{"name": n, "direction": d, "message": m, "msgpack_hex": msgpack.packb(m).hex()}
               for n, d, m in MESSAGES]
    (HERE / "messages.json").write_text(json.dumps({"version": 1, "vectors": vectors}, indent=1) + "\n")
    invalid = [{"name": n, "msgpack_hex": b.hex(), "code": c} for n, b, c in INVALID]
    (HERE / "invalid.json").write_text(json.dumps({"version": 1, "frames": invalid}, indent=1) + "\n")
    coords = {
        "note": "scene frame: x toward viewer, y right, z up (right-handed); see docs/protocol.md",
        "points": [{"scene": p, "three": three(p), "unity": unity(p)} for p in POINTS],
        "rotations": [{"scene": q, "three": quat_three(q), "unity_xyzw": quat_unity_xyzw(q)} for q in ROTATIONS],
    }
    (HERE / "coordinates.json").write_text(json.dumps(coords, indent=1) + "\n")


if __name__ == "__main__":
    main()
