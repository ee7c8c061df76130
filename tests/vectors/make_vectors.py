"""Writes the shared wire-protocol test vectors (run once; the output is committed, and running it
again must give identical files).

The bytes are produced with the msgpack library directly from hand-written canonical maps
(integral numbers already as ints, fields in documented order), not with server/wire, so the
vectors check the codec instead of restating it. Every client codec (Python, JS, C#) must
reproduce the bytes of the messages it sends and decode every vector to its message. The scene
hashes are computed here from docs/protocol.md's recipe, again without server code.
"""

import hashlib
import json
import math
import struct
from pathlib import Path

import msgpack

HERE = Path(__file__).parent
H = math.sqrt(0.5)


def text(message) -> str:
    """JSON text as the encoders write it: declared order, no whitespace, UTF-8 as is."""
    return json.dumps(message, separators=(",", ":"), ensure_ascii=False, allow_nan=False)


def plain_canonical_json(value) -> str:
    """docs/protocol.md "Scene hash", step 3, for maps whose keys are ASCII and whose floats Python
    writes without an exponent: then sorted keys and Python's shortest float digits are exactly
    RFC 8785's text. The edge cases outside that are written by hand in SCENE_HASH_EDGES."""
    def walk(v):
        if isinstance(v, float):
            assert not v.is_integer() and "e" not in repr(v), f"{v!r}: not a plain-canonical number"
        elif isinstance(v, dict):
            assert all(k.isascii() for k in v)
            for x in v.values():
                walk(x)
        elif isinstance(v, list):
            for x in v:
                walk(x)
    walk(value)
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=False)


def scene_hash(scene: dict) -> str:
    return hashlib.sha256(plain_canonical_json(scene).encode("utf-8")).hexdigest()[:16]


# ---- scenes -------------------------------------------------------------------------------------

SCENE_MINIMAL = {
    "name": "demo",
    "camera": {"projection": "orthographic", "position": [5, 0, 0.35], "target": [0, 0, 0.35],
               "up": [0, 0, 1], "height": 1.6},
    "hip": {"radius": 0.06, "proxy_radius": 0.06, "color": "#ffd400"},
    "objects": [{"id": "dome", "shape": {"type": "hemisphere", "radius": 0.6},
                 "pose": {"pos": [0, 0, 0], "quat": [1, 0, 0, 0]},
                 "material": {"color": "#3a7bd5", "opacity": 1, "stiffness_n_per_m": 1000,
                              "static_friction": 0, "dynamic_friction": 0},
                 "haptic": True, "visible": True}],
    "hud": {"text": "touch the dome"}}

SCENE_AIDS = {
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
                  "size": 0.12, "color": "#1b1b1b", "visible": True}]}

SCENE_TABLE = {
    "name": "Tisch – Würfel",
    "camera": {"projection": "perspective", "position": [2.2, -1.1, 1.35], "target": [0, 0, 0.4],
               "up": [0, 0, 1], "fov_deg": 40},
    "hip": {"radius": 0.03, "proxy_radius": 0, "color": "#ffd400"},
    "objects": [{"id": "top", "shape": {"type": "box", "size": [1.2, 0.8, 0.05]},
                 "pose": {"pos": [0, 0, 0.375], "quat": [1, 0, 0, 0]},
                 "material": {"color": "#b89f7a", "opacity": 1, "stiffness_n_per_m": 2500,
                              "static_friction": 0.4, "dynamic_friction": 0.3},
                 "haptic": True, "visible": True},
                {"id": "cube", "shape": {"type": "box", "size": [0.1, 0.1, 0.1]},
                 "pose": {"pos": [0.2, -0.15, 0.45], "quat": [H, 0, 0, H]},
                 "material": {"color": "#3a7bd5", "opacity": 0.75, "stiffness_n_per_m": 800,
                              "static_friction": 0, "dynamic_friction": 0},
                 "haptic": True, "visible": True},
                {"id": "leg", "shape": {"type": "mesh", "vertices": [[0, 0, 0], [0.05, 0, 0], [0, 0.05, 0],
                                                                       [0, 0, 0.35]],
                                        "faces": [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]]},
                 "pose": {"pos": [0.5, 0.3, 0], "quat": [1, 0, 0, 0]},
                 "material": {"color": "#6f7378", "opacity": 1, "stiffness_n_per_m": 1000,
                              "static_friction": 0, "dynamic_friction": 0},
                 "haptic": False, "visible": True}],
    "hud": {"text": "Heb den Würfel auf \"jetzt\"\n→ 😀"}}

HASH_MINIMAL, HASH_AIDS, HASH_TABLE = scene_hash(SCENE_MINIMAL), scene_hash(SCENE_AIDS), scene_hash(SCENE_TABLE)

# ---- valid messages (canonical: what every encoder writes) ----------------------------------------

TELEMETRY = {"period_p50_us": 1000, "period_p99_us": 1026.5, "period_max_us": 1180, "overruns": 0,
             "tick_cost_p99_us": 31.2, "ticks": 20016, "rt": True}

MESSAGES = [
    ("hello-participant", "client_to_server",
     {"type": "hello", "v": 1, "role": "participant", "client": "viestac-web/0.1"}),
    ("hello-observer", "client_to_server",
     {"type": "hello", "v": 1, "role": "observer", "client": ""}),
    ("hello-operator-64-code-points", "client_to_server",
     {"type": "hello", "v": 1, "role": "operator", "client": "😀" * 64}),
    ("hello-with-token", "client_to_server",
     {"type": "hello", "v": 1, "role": "operator", "client": "viestac-console/0.1",
      "token": "q3Jx0N6b1d2Zc8wYkU4mT7rVhA9sLpE5gFiK_oWjQ-Y"}),
    ("hello-token-200-code-points", "client_to_server",
     {"type": "hello", "v": 1, "role": "participant", "client": "", "token": "t" * 200}),
    ("tracker-position", "client_to_server",
     {"type": "tracker", "seq": 42, "t": 1234.5, "pos": [0.125, -0.6, 0.3]}),
    ("tracker-integral-coordinates", "client_to_server",
     {"type": "tracker", "seq": 0, "t": 0, "pos": [0, 1, -2]}),
    ("tracker-with-orientation", "client_to_server",
     {"type": "tracker", "seq": 70000, "t": 98765.25, "pos": [0.01, 0.02, 0.03],
      "quat": [0.7071067811865476, 0, 0.7071067811865476, 0]}),
    ("tracker-largest-seq", "client_to_server",
     {"type": "tracker", "seq": 2**53 - 1, "t": 1700000000123.25, "pos": [-0.5, 0.25, 1]}),
    # v1.4: several points of one sample (a hand), the point pos is, and how long it is good for
    ("tracker-thumb-ttl", "client_to_server",
     {"type": "tracker", "seq": 11, "t": 5000.25, "pos": [0.1, 0.05, 0.4], "point": "right.thumb.tip", "ttl": 36.4}),
    ("tracker-hand-points", "client_to_server",
     {"type": "tracker", "seq": 12, "t": 5009.34, "pos": [0.12, -0.02, 0.45],
      "points": {"right.thumb.tip": [0.1, 0.05, 0.4], "right.palm": [0.05, 0, 0.55],
                 "right.index.distal": [0.11, -0.02, 0.47]}, "ttl": 40}),
    ("tracker-left-index-points-empty", "client_to_server",
     {"type": "tracker", "seq": 13, "t": 0, "pos": [-0.2, 0, 0.3], "point": "left.index.tip", "points": {}}),
    ("input-key-down", "client_to_server", {"type": "input", "key": "ArrowUp", "action": "down"}),
    ("input-space-press", "client_to_server", {"type": "input", "key": " ", "action": "press"}),
    ("input-command-value", "client_to_server",
     {"type": "input", "key": "tap_angle", "action": "press", "value": -30}),
    ("input-command-float", "client_to_server",
     {"type": "input", "key": "tap_angle", "action": "press", "value": 12.5}),
    ("input-command-bool", "client_to_server", {"type": "input", "key": "scale", "action": "press", "value": False}),
    ("input-command-text", "client_to_server",
     {"type": "input", "key": "note", "action": "press", "value": "Größe ≈ 3 cm"}),
    # v1.5: a participant answers a question of its session's running trial
    ("answer-likert", "client_to_server", {"type": "answer", "seq": 4, "question": "roughness", "value": 6}),
    ("answer-choice-text", "client_to_server",
     {"type": "answer", "seq": 0, "question": "which", "value": "all felt the same"}),
    ("answer-angle", "client_to_server", {"type": "answer", "seq": 12, "question": "angle_deg", "value": -22.5}),
    ("answer-pacing-continue", "client_to_server",
     {"type": "answer", "seq": 0, "question": "pacing:continue", "value": 1}),
    # v1.6: a participant page offers its own actuators (the rig's browser device)
    ("actuators-xr-both-hands", "client_to_server",
     {"type": "actuators", "actuators": [["xr", "right"], ["xr", "left"]]}),
    ("actuators-gamepad", "client_to_server", {"type": "actuators", "actuators": [["gamepad", "none"]]}),
    ("actuators-none-tracked-hands", "client_to_server",
     {"type": "actuators", "actuators": [], "note": "tracked hands have no actuator"}),
    ("welcome", "server_to_client",
     {"type": "welcome", "v": 1, "minor": 3, "client_id": 7, "role": "participant", "server": "viestac/0.1.0",
      "tick_hz": 1000, "state_hz": 60, "format": "msgpack",
      "identity": {"token_id": "3fa9c2d1", "role": "participant", "site": "lab-a", "session": "s-0007"}}),
    ("welcome-json-observer", "server_to_client",
     {"type": "welcome", "v": 1, "minor": 3, "client_id": 12, "role": "observer", "server": "viestac/0.1.0",
      "tick_hz": 1000, "state_hz": 62.5, "format": "json",
      "identity": {"token_id": "0b7e41aa", "role": "admin", "site": None, "session": None}}),
    ("scene-minimal", "server_to_client", {"type": "scene", "v": 1, "hash": HASH_MINIMAL, "scene": SCENE_MINIMAL}),
    ("scene-overlays-skin", "server_to_client", {"type": "scene", "v": 1, "hash": HASH_AIDS, "scene": SCENE_AIDS}),
    ("scene-perspective-mesh", "server_to_client", {"type": "scene", "v": 1, "hash": HASH_TABLE, "scene": SCENE_TABLE}),
    ("state-in-contact", "server_to_client",
     {"type": "state", "frame": 1201, "tick": 20016, "t": 20.016, "scene": HASH_MINIMAL,
      "hip": [0, -0.2, 0.55], "proxy": [0, -0.2012, 0.5644], "force": [0, -1.2, 14.4],
      "contact": True, "contacts": [["dome", [0, -0.3354, 0.9421], 0.0153]],
      "objects": [], "cues": [{"kind": "tilt", "direction_deg": 20.5, "magnitude_pct": 100}],
      "hud": "", "values": {"angle_deg": -20.5}, "telemetry": TELEMETRY,
      "visible": {"angle_scale": False},
      "events": [{"tick": 20010, "t": 20.01, "name": "tap", "angle_deg": -20.5}],
      "scales": {}, "stiffness": {"dome": 450.5}, "haptic": {}, "driver": [7, 1042]}),
    ("state-free-moving-objects", "server_to_client",
     {"type": "state", "frame": 3, "tick": 50, "t": 812.050113, "scene": HASH_TABLE,
      "hip": [0.4, 0.3, 0.9], "proxy": [0.4, 0.3, 0.9], "force": [0, 0, 0], "contact": False,
      "contacts": [], "objects": [["cube", [0.2, -0.15, 0.525], [H, 0, 0, H]]],
      "cues": [{"kind": "pulse_train", "t_on_ms": 50, "t_off_ms": 200, "intensity_pct": 80, "carrier_hz": 235},
               {"kind": "stop"}],
      "hud": "Pick up the cube", "values": {}, "telemetry": TELEMETRY, "visible": {"leg": False}, "events": [],
      "scales": {"top": [1.5, 1.5, 1]}, "stiffness": {}, "haptic": {"cube": False},
      "driver": ["udp:127.0.0.1:50123", 9]}),
    ("state-nobody-drives", "server_to_client",
     {"type": "state", "frame": 1, "tick": 0, "t": 0.5, "scene": HASH_AIDS,
      "hip": [0.5, 0, 1.2], "proxy": [0.5, 0, 1.2], "force": [0, 0, 0], "contact": False,
      "contacts": [], "objects": [], "cues": [], "hud": "", "values": {}, "telemetry": TELEMETRY,
      "visible": {}, "events": [], "scales": {}, "stiffness": {}, "haptic": {}, "driver": None}),
    ("state-two-tools-hand-lost-source", "server_to_client",
     {"type": "state", "frame": 77, "tick": 4200, "t": 31.2, "scene": HASH_MINIMAL,
      "hip": [0, 0.05, 0.61], "proxy": [0, 0.05, 0.66], "force": [0, 0, 50], "contact": True,
      "contacts": [["dome", [0, 0.0833, 0.9965], 0.05]], "objects": [],
      "cues": [{"kind": "tilt", "direction_deg": 4.8, "magnitude_pct": 100}], "hud": "", "values": {},
      "telemetry": TELEMETRY, "visible": {}, "events": [
          {"tick": 4150, "t": 4.15, "name": "tracker_lost", "source": "udp:127.0.0.1:40001",
           "tools": ["right.thumb.tip"]}],
      "scales": {}, "stiffness": {}, "haptic": {}, "driver": [3, 880],
      "tools": [{"name": "right.index.tip", "hip": [0, 0.05, 0.61], "proxy": [0, 0.05, 0.66], "contact": True,
                 "lost": False},
                {"name": "right.thumb.tip", "hip": [0.5, 0, 1.2], "proxy": [0.5, 0, 1.2], "contact": False,
                 "lost": True}],
      "points": {"right.wrist": [0.02, 0.1, 0.8], "right.index.distal": [0.01, 0.06, 0.65]},
      "tracking": {"lost": ["udp:127.0.0.1:40001"]}}),
    ("state-browser-actuator-pulse-train", "server_to_client",
     {"type": "state", "frame": 310, "tick": 5170, "t": 5.17, "scene": HASH_MINIMAL,
      "hip": [0, 0, 1], "proxy": [0, 0, 1], "force": [0, 0, 0], "contact": False, "contacts": [], "objects": [],
      "cues": [{"kind": "pulse_train", "t_on_ms": 100, "t_off_ms": 200, "intensity_pct": 60, "duration_ms": 900}],
      "hud": "Interval 1", "values": {}, "telemetry": TELEMETRY, "visible": {}, "events": [], "scales": {},
      "stiffness": {}, "haptic": {}, "driver": None, "actuator": [0.6, 100, 200, 900, 5170]}),
    ("error-bad-message", "server_to_client",
     {"type": "error", "code": "bad_message", "message": "'pos' must be an array of 3 numbers"}),
    ("error-unsupported-version", "server_to_client",
     {"type": "error", "code": "unsupported_version",
      "message": "protocol version 2 is not supported; this server speaks v1"}),
    ("error-unauthorized", "server_to_client",
     {"type": "error", "code": "unauthorized", "message": "no valid token: unknown, expired or revoked"}),
    ("health-ok", "server_to_client", {"type": "health", "status": "ok", "reasons": []}),
    ("health-degraded", "server_to_client",
     {"type": "health", "status": "degraded", "reasons": [
         {"code": "device_missing", "message": "device 'ferrovibe' is disconnected: check its cable and power; "
                                               "the running scenario 'contact-angle' needs it for macro-roughness (tilt)"},
         {"code": "loop_stalled", "message": "the haptic loop has not ticked for 0.07 s"}]}),
    ("lease-free", "server_to_client",
     {"type": "lease", "holder": None, "queue": [], "session": None, "ttl_s": 60}),
    ("lease-held-queued-open-session", "server_to_client",
     {"type": "lease",
      "holder": {"token_id": "5d0c9e12", "role": "experimenter", "site": "lab-a", "label": "Anna",
                 "since": 1767225600.5, "expires_at": 1767225660.5},
      "queue": [{"token_id": "a1b2c3d4", "role": "experimenter", "site": "lab-b", "label": "Ben", "position": 1}],
      "session": "s-0007", "ttl_s": 60}),
    ("ask-likert-audio", "server_to_client",
     {"type": "ask", "session": "s-0007", "seq": 4, "task": "texture_pairs",
      "questions": [{"id": "roughness", "kind": "likert", "text": "How rough was the second texture?", "low": 1,
                     "high": 7, "integer": False, "labels": {"1": "much smoother", "4": "same", "7": "much rougher"},
                     "choices": [], "required": True, "answered_by": "participant", "answer": None}],
      "audio": {"speech": True, "contact_sounds": False}, "instructions": "Touch both textures, then answer."}),
    ("ask-nothing-running", "server_to_client",
     {"type": "ask", "session": "s-0007", "seq": None, "task": None, "questions": [],
      "audio": {"speech": False, "contact_sounds": False}, "instructions": ""}),
    ("ask-paced-choice", "server_to_client",
     {"type": "ask", "session": "s-0007", "seq": 12, "task": "detect",
      "questions": [{"id": "response", "kind": "choice", "text": "Which interval held the stimulus?", "low": None,
                     "high": None, "integer": False, "labels": {}, "choices": ["1", "2"], "required": True,
                     "answered_by": "participant", "answer": None}],
      "audio": {"speech": False, "contact_sounds": False}, "instructions": "",
      "pacing": {"state": "trial", "done": 12, "total": 60, "feedback": None}}),
    ("ask-paced-break", "server_to_client",
     {"type": "ask", "session": "s-0007", "seq": None, "task": "detect", "questions": [],
      "audio": {"speech": False, "contact_sounds": False}, "instructions": "",
      "pacing": {"state": "break", "done": 20, "total": 60, "feedback": None}}),
]

# ---- frames a receiver accepts although no canonical encoder writes them --------------------------


def f64(x: float) -> bytes:
    return struct.pack(">Bd", 0xCB, x)


def pack_with(fields: list[tuple[str, bytes]]) -> bytes:
    """A msgpack map from (key, already packed value) pairs: floats where ints would go."""
    assert len(fields) < 16
    return bytes([0x80 | len(fields)]) + b"".join(msgpack.packb(k) + v for k, v in fields)


def packed(value) -> bytes:
    return msgpack.packb(value)


RECEIVED = [
    # name, direction, msgpack bytes, JSON text, the message as a receiver understands it
    ("tracker-seq-as-float", "client_to_server",
     pack_with([("type", packed("tracker")), ("seq", f64(3.0)), ("t", f64(10.0)),
                ("pos", bytes([0x93]) + f64(0.0) + f64(1.0) + packed(0.25))]),
     '{"type":"tracker","seq":3.0,"t":10.0,"pos":[0.0,1.0,0.25]}',
     {"type": "tracker", "seq": 3, "t": 10, "pos": [0, 1, 0.25]}),
    ("hello-v-as-float", "client_to_server",
     pack_with([("type", packed("hello")), ("v", f64(1.0)), ("role", packed("participant")),
                ("client", packed("unity/2022.3"))]),
     '{"type":"hello","v":1.0,"role":"participant","client":"unity/2022.3"}',
     {"type": "hello", "v": 1, "role": "participant", "client": "unity/2022.3"}),
    ("tracker-quat-norm-2", "client_to_server",
     packed({"type": "tracker", "seq": 5, "t": 0, "pos": [0, 0, 0], "quat": [0, 0, 0, 2]}),
     '{"type":"tracker","seq":5,"t":0,"pos":[0,0,0],"quat":[0,0,0,2]}',
     {"type": "tracker", "seq": 5, "t": 0, "pos": [0, 0, 0], "quat": [0, 0, 0, 1]}),
    ("tracker-quat-norm-0.5", "client_to_server",
     packed({"type": "tracker", "seq": 6, "t": 0, "pos": [0, 0, 0], "quat": [0.3, 0, 0.4, 0]}),
     '{"type":"tracker","seq":6,"t":0,"pos":[0,0,0],"quat":[0.3,0,0.4,0]}',
     {"type": "tracker", "seq": 6, "t": 0, "pos": [0, 0, 0], "quat": [0.6, 0, 0.8, 0]}),
    ("tracker-quat-float32-unit", "client_to_server",
     packed({"type": "tracker", "seq": 7, "t": 0, "pos": [0, 0, 0],
             "quat": [0.7071067690849304, 0, 0, 0.7071067690849304]}),
     '{"type":"tracker","seq":7,"t":0,"pos":[0,0,0],"quat":[0.7071067690849304,0,0,0.7071067690849304]}',
     {"type": "tracker", "seq": 7, "t": 0, "pos": [0, 0, 0], "quat": [H, 0, 0, H]}),
    ("tracker-quat-null", "client_to_server",
     packed({"type": "tracker", "seq": 8, "t": 0, "pos": [0, 0, 0], "quat": None}),
     '{"type":"tracker","seq":8,"t":0,"pos":[0,0,0],"quat":null}',
     {"type": "tracker", "seq": 8, "t": 0, "pos": [0, 0, 0]}),
    ("tracker-unknown-field", "client_to_server",
     packed({"type": "tracker", "seq": 9, "t": 0, "pos": [0, 0, 0], "confidence": 0.9}),
     '{"type":"tracker","seq":9,"t":0,"pos":[0,0,0],"confidence":0.9}',
     {"type": "tracker", "seq": 9, "t": 0, "pos": [0, 0, 0]}),
    ("hello-without-client", "client_to_server",
     packed({"type": "hello", "v": 1, "role": "observer"}), '{"type":"hello","v":1,"role":"observer"}',
     {"type": "hello", "v": 1, "role": "observer", "client": ""}),
    ("input-value-null", "client_to_server",
     packed({"type": "input", "key": "r", "action": "up", "value": None}),
     '{"type":"input","key":"r","action":"up","value":null}',
     {"type": "input", "key": "r", "action": "up"}),
    ("hello-token-null", "client_to_server",
     packed({"type": "hello", "v": 1, "role": "observer", "client": "x", "token": None}),
     '{"type":"hello","v":1,"role":"observer","client":"x","token":null}',
     {"type": "hello", "v": 1, "role": "observer", "client": "x"}),
    ("welcome-v1.2-server", "server_to_client",
     packed({"type": "welcome", "v": 1, "minor": 2, "client_id": 4, "role": "participant", "server": "viestac/0.1.0",
             "tick_hz": 1000, "state_hz": 60, "format": "msgpack"}),
     '{"type":"welcome","v":1,"minor":2,"client_id":4,"role":"participant","server":"viestac/0.1.0","tick_hz":1000,'
     '"state_hz":60,"format":"msgpack"}',
     {"type": "welcome", "v": 1, "minor": 2, "client_id": 4, "role": "participant", "server": "viestac/0.1.0",
      "tick_hz": 1000, "state_hz": 60, "format": "msgpack"}),
    ("welcome-v1.0-server", "server_to_client",
     packed({"type": "welcome", "v": 1, "client_id": 3, "role": "observer", "server": "viestac/0.0.9",
             "tick_hz": 1000, "state_hz": 60, "format": "msgpack"}),
     '{"type":"welcome","v":1,"client_id":3,"role":"observer","server":"viestac/0.0.9","tick_hz":1000,'
     '"state_hz":60,"format":"msgpack"}',
     {"type": "welcome", "v": 1, "client_id": 3, "role": "observer", "server": "viestac/0.0.9",
      "tick_hz": 1000, "state_hz": 60, "format": "msgpack"}),
]
V10_STATE = {"type": "state", "frame": 9, "tick": 150, "t": 2.5, "scene": HASH_MINIMAL, "hip": [0, 0, 1],
             "proxy": [0, 0, 1], "force": [0, 0, 0], "contact": False, "contacts": [], "objects": [], "cues": [],
             "hud": "", "values": {}, "telemetry": TELEMETRY}
RECEIVED.append(("state-v1.0-server", "server_to_client", packed(V10_STATE), text(V10_STATE), V10_STATE))

# ---- frames refused, with the error code ------------------------------------------------------------

NAN = f64(math.nan)
INF = f64(math.inf)


def _nested(depth: int) -> list:
    value: list = []
    for _ in range(depth - 1):
        value = [value]
    return value


def tracker_with(pos_bytes: bytes) -> bytes:
    head = msgpack.packb({"type": "tracker", "seq": 1, "t": 0})[1:]  # drop the fixmap header
    return bytes([0x84]) + head + msgpack.packb("pos") + bytes([0x93]) + pos_bytes


def bad(name: str, message, code: str):
    """A refused frame whose content JSON can carry too."""
    return name, packed(message), text(message), code


INVALID = [
    ("not-msgpack", bytes([0xC1, 0x00, 0x01]), None, "bad_encoding"),
    ("truncated-map", bytes([0x82, 0xA4]) + b"ty", '{"type":"tr', "bad_encoding"),
    bad("array-not-map", [1, 2, 3], "bad_message"),
    bad("no-type", {"seq": 1}, "bad_message"),
    bad("type-not-string", {"type": 5}, "bad_message"),
    bad("unknown-type", {"type": "teleport", "pos": [0, 0, 0]}, "unknown_type"),
    ("tracker-nan", tracker_with(NAN + packed(0) + packed(0)), None, "non_finite"),
    ("tracker-inf", tracker_with(packed(0) + INF + packed(0)), None, "non_finite"),
    bad("tracker-pos-string", {"type": "tracker", "seq": 1, "t": 0, "pos": "0,0,0"}, "bad_message"),
    bad("tracker-pos-two", {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0]}, "bad_message"),
    bad("tracker-seq-negative", {"type": "tracker", "seq": -1, "t": 0, "pos": [0, 0, 0]}, "bad_message"),
    bad("tracker-pos-bool", {"type": "tracker", "seq": 1, "t": 0, "pos": [True, 0, 0]}, "bad_message"),
    bad("input-bad-action", {"type": "input", "key": "a", "action": "hold"}, "bad_message"),
    bad("input-value-map", {"type": "input", "key": "tap_angle", "action": "press", "value": {"a": 1}}, "bad_message"),
    bad("hello-bad-role", {"type": "hello", "v": 1, "role": "admin", "client": ""}, "bad_message"),
    bad("hello-v-fraction", {"type": "hello", "v": 1.5, "role": "participant", "client": ""}, "bad_message"),
    bad("hello-v-string", {"type": "hello", "v": "1", "role": "participant", "client": ""}, "bad_message"),
    bad("hello-v-missing", {"type": "hello", "role": "participant", "client": ""}, "bad_message"),
    bad("hello-client-65-code-points", {"type": "hello", "v": 1, "role": "operator", "client": "😀" * 65},
        "bad_message"),
    bad("hello-token-201-code-points", {"type": "hello", "v": 1, "role": "participant", "client": "",
                                        "token": "t" * 201}, "bad_message"),
    bad("hello-token-number", {"type": "hello", "v": 1, "role": "participant", "client": "", "token": 12345},
        "bad_message"),
    bad("tracker-seq-fraction", {"type": "tracker", "seq": 2.5, "t": 0, "pos": [0, 0, 0]}, "bad_message"),
    bad("tracker-seq-beyond-2^53", {"type": "tracker", "seq": 2**53, "t": 0, "pos": [0, 0, 0]}, "out_of_range"),
    bad("tracker-t-missing", {"type": "tracker", "seq": 1, "pos": [0, 0, 0]}, "bad_message"),
    bad("tracker-t-string", {"type": "tracker", "seq": 1, "t": "now", "pos": [0, 0, 0]}, "bad_message"),
    bad("tracker-quat-zero", {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 0], "quat": [0, 0, 0, 0]},
        "bad_message"),
    bad("tracker-quat-norm-2.5", {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 0], "quat": [1.5, 0, 2, 0]},
        "bad_message"),
    bad("tracker-quat-norm-0.4", {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 0], "quat": [0, 0.4, 0, 0]},
        "bad_message"),
    bad("tracker-quat-three", {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 0], "quat": [1, 0, 0]},
        "bad_message"),
    bad("actuators-kind-unknown", {"type": "actuators", "actuators": [["glove", "right"]]}, "bad_message"),
    bad("actuators-hand-missing", {"type": "actuators", "actuators": [["xr"]]}, "bad_message"),
    bad("actuators-missing", {"type": "actuators", "note": "none"}, "bad_message"),
    bad("actuators-note-201", {"type": "actuators", "actuators": [], "note": "n" * 201}, "bad_message"),
    bad("answer-seq-negative", {"type": "answer", "seq": -1, "question": "q", "value": 3}, "bad_message"),
    bad("answer-question-empty", {"type": "answer", "seq": 1, "question": "", "value": 3}, "bad_message"),
    bad("answer-value-bool", {"type": "answer", "seq": 1, "question": "q", "value": True}, "bad_message"),
    bad("answer-value-missing", {"type": "answer", "seq": 1, "question": "q"}, "bad_message"),
    bad("input-key-empty", {"type": "input", "key": "", "action": "down"}, "bad_message"),
    bad("input-key-33", {"type": "input", "key": "k" * 33, "action": "down"}, "bad_message"),
    bad("input-action-missing", {"type": "input", "key": "r"}, "bad_message"),
    bad("input-value-201", {"type": "input", "key": "note", "action": "press", "value": "x" * 201}, "bad_message"),
    bad("input-value-array", {"type": "input", "key": "tap_angle", "action": "press", "value": [30]}, "bad_message"),
    # Issue 18: bounds (docs/protocol.md "Bounds"), non-finite numbers anywhere, nesting.
    bad("tracker-pos-1e154", {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 1e154, 0.5]}, "out_of_range"),
    bad("tracker-pos-outside-workspace", {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, -10.001]},
        "out_of_range"),
    bad("tracker-seq-2^64-1", {"type": "tracker", "seq": 2**64 - 1, "t": 0, "pos": [0, 0, 0]}, "out_of_range"),
    bad("tracker-t-2^60", {"type": "tracker", "seq": 1, "t": 2**60, "pos": [0, 0, 0]}, "out_of_range"),
    ("unknown-field-infinity", packed({"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 0], "x": math.inf}),
     '{"type":"tracker","seq":1,"t":0,"pos":[0,0,0],"x":1e999}', "non_finite"),
    bad("tracker-point-unknown", {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 0], "point": "right.index.nail"},
        "bad_message"),
    bad("tracker-point-number", {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 0], "point": 3}, "bad_message"),
    bad("tracker-points-key-unknown", {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 0],
                                       "points": {"thumb": [0, 0, 0]}}, "bad_message"),
    bad("tracker-points-two", {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 0],
                               "points": {"right.thumb.tip": [0, 0]}}, "bad_message"),
    bad("tracker-points-array", {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 0],
                                 "points": [[0, 0, 0]]}, "bad_message"),
    bad("tracker-points-outside-workspace", {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 0],
                                             "points": {"right.palm": [0, 10.5, 0]}}, "out_of_range"),
    bad("tracker-ttl-zero", {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 0], "ttl": 0}, "bad_message"),
    bad("tracker-ttl-over-10-s", {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 0], "ttl": 10000.5},
        "bad_message"),
    bad("tracker-ttl-string", {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 0], "ttl": "50"}, "bad_message"),
    bad("tracker-pos-nested-40-deep", {"type": "tracker", "seq": 1, "t": 0, "pos": _nested(40)}, "bad_message"),
]

SERVER_STATE = {"type": "state", "frame": 1, "tick": 16, "t": 0.016, "scene": HASH_MINIMAL, "hip": [0, 0, 1],
                "proxy": [0, 0, 1], "force": [0, 0, 0], "contact": False, "contacts": [], "objects": [], "cues": [],
                "hud": "", "values": {}, "telemetry": TELEMETRY, "visible": {}, "events": [], "scales": {},
                "stiffness": {}, "haptic": {}, "driver": None}
WELCOME = next(m for n, _, m in MESSAGES if n == "welcome")


def state(**changes):
    body = {**SERVER_STATE, **changes}
    return {k: v for k, v in body.items() if v is not ...}


INVALID_SERVER = [
    bad("welcome-no-client-id", {k: v for k, v in WELCOME.items() if k != "client_id"}, "bad_message"),
    bad("welcome-format-xml", {**WELCOME, "format": "xml"}, "bad_message"),
    bad("welcome-minor-fraction", {**WELCOME, "minor": 1.5}, "bad_message"),
    bad("welcome-state-hz-zero", {**WELCOME, "state_hz": 0}, "bad_message"),
    bad("scene-hash-number", {"type": "scene", "v": 1, "hash": 1234, "scene": SCENE_MINIMAL}, "bad_message"),
    bad("scene-not-a-map", {"type": "scene", "v": 1, "hash": HASH_MINIMAL, "scene": [SCENE_MINIMAL]}, "bad_message"),
    bad("state-hip-missing", state(hip=...), "bad_message"),
    bad("state-hip-two", state(hip=[0, 1]), "bad_message"),
    bad("state-frame-fraction", state(frame=1.5), "bad_message"),
    bad("state-contact-int", state(contact=1), "bad_message"),
    bad("state-contacts-entry-short", state(contacts=[["dome", [0, 0, 1]]]), "bad_message"),
    bad("state-contacts-depth-negative", state(contacts=[["dome", [0, 0, 1], -0.01]]), "bad_message"),
    bad("state-objects-quat-zero", state(objects=[["cube", [0, 0, 0], [0, 0, 0, 0]]]), "bad_message"),
    bad("state-cues-not-maps", state(cues=["tilt"]), "bad_message"),
    bad("state-actuator-value-above-1", state(actuator=[1.5, 0, 0, 0, 16]), "bad_message"),
    bad("state-actuator-four-items", state(actuator=[0.5, 0, 0, 0]), "bad_message"),
    bad("state-visible-not-bool", state(visible={"dome": 0}), "bad_message"),
    bad("state-scales-two", state(scales={"dome": [1, 2]}), "bad_message"),
    bad("state-stiffness-negative", state(stiffness={"dome": -5}), "bad_message"),
    bad("state-haptic-not-bool", state(haptic={"dome": "yes"}), "bad_message"),
    bad("state-driver-one-item", state(driver=[7]), "bad_message"),
    bad("state-driver-seq-fraction", state(driver=[7, 0.5]), "bad_message"),
    bad("state-driver-id-bool", state(driver=[True, 3]), "bad_message"),
    bad("state-tools-not-array", state(tools={"name": "right.index.tip"}), "bad_message"),
    bad("state-points-key-unknown", state(points={"nail": [0, 0, 0]}), "bad_message"),
    bad("state-tracking-not-map", state(tracking=["udp:127.0.0.1:1"]), "bad_message"),
    ("state-t-nan", pack_with([("type", packed("state")), ("frame", packed(1)), ("tick", packed(1)), ("t", NAN)]),
     None, "non_finite"),
    bad("error-code-number", {"type": "error", "code": 3, "message": "x"}, "bad_message"),
    bad("error-message-missing", {"type": "error", "code": "busy"}, "bad_message"),
    bad("welcome-identity-not-a-map", {**WELCOME, "identity": "admin"}, "bad_message"),
    bad("lease-queue-missing", {"type": "lease", "holder": None, "session": None, "ttl_s": 60}, "bad_message"),
    bad("lease-holder-string", {"type": "lease", "holder": "anna", "queue": [], "session": None, "ttl_s": 60},
        "bad_message"),
    bad("lease-ttl-zero", {"type": "lease", "holder": None, "queue": [], "session": None, "ttl_s": 0}, "bad_message"),
    bad("ask-questions-missing", {"type": "ask", "session": "s", "seq": None, "task": None,
                                  "audio": {"speech": False, "contact_sounds": False}, "instructions": ""},
        "bad_message"),
    bad("ask-audio-not-bool", {"type": "ask", "session": "s", "seq": 1, "task": "t", "questions": [],
                               "audio": {"speech": "yes"}, "instructions": ""}, "bad_message"),
    bad("ask-pacing-not-a-map", {"type": "ask", "session": "s", "seq": 1, "task": "t", "questions": [],
                                 "audio": {"speech": False, "contact_sounds": False}, "instructions": "",
                                 "pacing": "break"}, "bad_message"),
    bad("health-status-unknown", {"type": "health", "status": "fine", "reasons": []}, "bad_message"),
    bad("health-reason-code-number", {"type": "health", "status": "degraded", "reasons": [{"code": 3}]},
        "bad_message"),
]

# ---- scene hash: canonical JSON and hash --------------------------------------------------------------

# Canonical text written by hand from RFC 8785 (keys in UTF-16 order: "a" < "é" (U+00E9) < "😀"
# (U+D83D U+DE00) < "\uffff"; numbers in ECMAScript form; strings escaped as JSON.stringify does).
EDGE_VALUE = {"\uffff": [0.000001, 1e-7, 1e21, 1.5e300, -0.0, 2.0**53, 0.1],
              "😀": "tab\there \"quoted\" \\ \x01 \u2028",
              "é": {"nested": [True, False, None, 1.0, -2.5]}, "a": 123456789012.25}
EDGE_TEXT = ('{"a":123456789012.25,"é":{"nested":[true,false,null,1,-2.5]},'
             '"😀":"tab\\there \\"quoted\\" \\\\ \\u0001 \u2028",'
             '"\uffff":[0.000001,1e-7,1e+21,1.5e+300,0,9007199254740992,0.1]}')
SCENE_HASH_CASES = [("scene-minimal", SCENE_MINIMAL, plain_canonical_json(SCENE_MINIMAL)),
                    ("scene-overlays-skin", SCENE_AIDS, plain_canonical_json(SCENE_AIDS)),
                    ("scene-perspective-mesh", SCENE_TABLE, plain_canonical_json(SCENE_TABLE)),
                    ("edge-cases", EDGE_VALUE, EDGE_TEXT)]
# float64 bit patterns and their ECMAScript spelling (the examples of RFC 8785, Appendix B, and more)
NUMBERS = [("0000000000000000", "0"), ("8000000000000000", "0"), ("0000000000000001", "5e-324"),
           ("8000000000000001", "-5e-324"), ("7fefffffffffffff", "1.7976931348623157e+308"),
           ("ffefffffffffffff", "-1.7976931348623157e+308"), ("4340000000000000", "9007199254740992"),
           ("c340000000000000", "-9007199254740992"), ("4430000000000000", "295147905179352830000"),
           ("44b52d02c7e14af5", "9.999999999999997e+22"), ("44b52d02c7e14af6", "1e+23"),
           ("44b52d02c7e14af7", "1.0000000000000001e+23"), ("444b1ae4d6e2ef4e", "999999999999999700000"),
           ("444b1ae4d6e2ef4f", "999999999999999900000"), ("444b1ae4d6e2ef50", "1e+21"),
           ("3eb0c6f7a0b5ed8c", "9.999999999999997e-7"), ("3eb0c6f7a0b5ed8d", "0.000001"),
           ("41b3de4355555553", "333333333.3333332"), ("41b3de4355555554", "333333333.33333325"),
           ("41b3de4355555555", "333333333.3333333"), ("41b3de4355555556", "333333333.3333334"),
           ("41b3de4355555557", "333333333.33333343"), ("becbf647612f3696", "-0.0000033333333333333333"),
           ("43143ff3c1cb0959", "1424953923781206.2"), ("3ff0000000000000", "1"), ("3fb999999999999a", "0.1"),
           ("3ee4f8b588e368f1", "0.00001"), ("3e7ad7f29abcaf48", "1e-7"), ("4415af1d78b58c40", "100000000000000000000")]

# ---- coordinates ------------------------------------------------------------------------------------


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
ROTATIONS = [[1, 0, 0, 0], [H, 0, 0, H], [H, H, 0, 0], [H, 0, H, 0], [0.5, 0.5, 0.5, 0.5]]

ABOUT_MESSAGES = {
    "what": "ViESTac wire protocol v1.3 (docs/protocol.md): valid messages of every type, both directions, "
            "both encodings.",
    "vectors": "Canonical messages. `message`: the decoded map (field order = the order encoders write); "
               "`msgpack_hex`: the exact msgpack bytes every encoder writes for it (canonical numbers: integral "
               "values below 2^53 as the smallest int, others float64); `json`: the JSON text (no whitespace, "
               "UTF-8). Decoders turn both into `message`; encoders of the `direction` write `msgpack_hex` "
               "byte for byte.",
    "received": "Frames a receiver of `direction` must accept although no canonical encoder writes them. "
                "`expect`: the message as the receiver understands it: integral floats in integer fields as "
                "integers, a quaternion divided by its norm (numbers compare within 1e-12), optional fields that "
                "were absent or null left out unless the field declares a default (hello.client: \"\"), fields "
                "not declared left out.",
    "direction": "client_to_server or server_to_client",
}
ABOUT_INVALID = {
    "what": "Frames a receiver refuses, with the protocol error code it answers (the connection stays open).",
    "frames": "client_to_server: what the server refuses (the web client's validator classifies them the same).",
    "server_frames": "server_to_client: what a client refuses.",
    "fields": "`msgpack_hex`: the frame on a msgpack connection; `json`: the same content as a JSON text frame, "
              "null when JSON cannot carry it (NaN, Infinity, raw msgpack); `code`: the error code for both.",
}
ABOUT_HASH = {
    "what": "docs/protocol.md, \"Scene hash\": hash = first 16 lowercase hex digits of SHA-256(UTF-8("
            "RFC 8785 canonical JSON of the scene map with canonical numbers)).",
    "cases": "`value`: a decoded scene map (or any map); `canonical`: its canonical JSON text; `hash`: the first "
             "16 hex digits of the SHA-256 of that text's UTF-8 bytes.",
    "numbers": "`bits`: a float64 as 16 hex digits (IEEE 754, big-endian); `canonical`: how canonical JSON "
               "writes it (ECMAScript Number::toString).",
}


def dump(name: str, data) -> None:
    (HERE / name).write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")


def main() -> None:
    vectors = [{"name": n, "direction": d, "type": m["type"], "message": m, "msgpack_hex": msgpack.packb(m).hex(),
                "json": text(m)} for n, d, m in MESSAGES]
    received = [{"name": n, "direction": d, "type": e["type"], "msgpack_hex": b.hex(), "json": j, "expect": e}
                for n, d, b, j, e in RECEIVED]
    for r in received:  # the JSON text and the bytes say the same thing
        assert json.loads(r["json"]) == msgpack.unpackb(bytes.fromhex(r["msgpack_hex"]))
    dump("messages.json", {"version": 1, "protocol": "1.3", "about": ABOUT_MESSAGES, "vectors": vectors,
                           "received": received})

    def frames(rows):
        return [{"name": n, "msgpack_hex": b.hex(), "json": j, "code": c} for n, b, j, c in rows]
    dump("invalid.json", {"version": 1, "protocol": "1.3", "about": ABOUT_INVALID, "frames": frames(INVALID),
                          "server_frames": frames(INVALID_SERVER)})
    cases = []
    for name, value, canonical in SCENE_HASH_CASES:
        cases.append({"name": name, "value": value, "canonical": canonical,
                      "hash": hashlib.sha256(canonical.encode("utf-8")).hexdigest()[:16]})
    dump("scene_hash.json", {"version": 1, "about": ABOUT_HASH, "cases": cases,
                             "numbers": [{"bits": b, "canonical": c} for b, c in NUMBERS]})
    coords = {
        "about": "scene frame: x toward viewer, y right, z up (right-handed); see docs/protocol.md, "
                 "\"Coordinates\". `points`: a scene position with its three.js [X, Y, Z] and Unity [X, Y, Z]; "
                 "`rotations`: a scene quaternion [w, x, y, z] with its three.js [w, X, Y, Z] and its Unity "
                 "Quaternion as [x, y, z, w].",
        "points": [{"scene": p, "three": three(p), "unity": unity(p)} for p in POINTS],
        "rotations": [{"scene": q, "three": quat_three(q), "unity_xyzw": quat_unity_xyzw(q)} for q in ROTATIONS],
    }
    dump("coordinates.json", coords)


if __name__ == "__main__":
    main()
