"""Leap Motion WebSocket protocol v6 (JSON): frames → named points, and points → frames.

The format, as the Leap Motion service (SDK v2–v4, "Orion") serves it on
ws://127.0.0.1:6437/v6.json and Ultraleap's UltraleapTrackingWebSocket bridge serves it for the
Gemini software (both documented by leapjs, the SDK's JavaScript client, protocol "v6"):
- on connect the service sends `{"serviceVersion": "...", "version": 6}`;
- the client may send `{"background": true}` (frames also while its app is not focused),
  `{"focused": true|false}`, `{"optimizeHMD": true|false}`, `{"enableGestures": false}`;
- events: `{"event": {"type": "deviceEvent", "state": {"attached": .., "streaming": .., ...}}}`;
- a frame: `id`, `timestamp` (µs, the service's clock), `currentFrameRate`, `hands[]`,
  `pointables[]` (+ `interactionBox`, `gestures`, `devices`, which we ignore).
  A hand: `id`, `type` ("left"|"right"), `confidence` (0..1), `palmPosition`, `wrist`, `elbow`,
  `palmNormal`, `direction`, `timeVisible`, ... A pointable: `id`, `handId`, `type` (0 thumb,
  1 index, 2 middle, 3 ring, 4 pinky), `tipPosition`, `dipPosition`, `pipPosition`,
  `mcpPosition`, `carpPosition`, `extended`, `length`, `width`, `direction`, ...
  Positions are [x, y, z] in millimetres relative to the device's centre (x right, y up, z
  towards the user).

Joint mapping to our names (server/core/points.py, WebXR joints name the *base* of their bone):
carpPosition → FINGER.metacarpal, mcpPosition → FINGER.proximal, pipPosition →
FINGER.intermediate, dipPosition → FINGER.distal, tipPosition → FINGER.tip. The Leap models the
thumb with a zero-length metacarpal, so its bones are shifted by one: thumb mcpPosition →
thumb.metacarpal, pipPosition → thumb.proximal, dipPosition → thumb.distal. palmPosition →
HAND.palm, wrist → HAND.wrist.

Pure: dicts in, dicts out (the shells do the JSON and the socket).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from server.core.points import FINGERS

VERSION = 6
NOMINAL_HZ = 110.0  # the Leap Motion Controller's usual frame rate in its balanced mode

_FINGER_JOINTS = (("carpPosition", "metacarpal"), ("mcpPosition", "proximal"), ("pipPosition", "intermediate"),
                  ("dipPosition", "distal"), ("tipPosition", "tip"))
_THUMB_JOINTS = (("mcpPosition", "metacarpal"), ("pipPosition", "proximal"), ("dipPosition", "distal"),
                 ("tipPosition", "tip"))


def _joints(finger: str):
    return _THUMB_JOINTS if finger == "thumb" else _FINGER_JOINTS


@dataclass(frozen=True)
class LeapFrame:
    frame_id: int
    timestamp_us: int
    points: dict           # point name → (x, y, z), mm, device frame
    confidence: dict       # hand ("left"/"right") → confidence 0..1
    frame_rate: float


def _vec(value) -> tuple[float, float, float] | None:
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        return None
    try:
        out = (float(value[0]), float(value[1]), float(value[2]))
    except (TypeError, ValueError):
        return None
    return out if all(math.isfinite(v) for v in out) else None


def kind_of(message: dict) -> str:
    """'frame', 'version', 'event' or 'other'."""
    if not isinstance(message, dict):
        return "other"
    if "hands" in message or "pointables" in message:
        return "frame"
    if "version" in message:
        return "version"
    if "event" in message:
        return "event"
    return "other"


def parse_frame(message: dict) -> LeapFrame:
    """A v6 frame → its points. Hands of an unknown `type` and malformed entries are skipped;
    when two hands claim one side (the service can, briefly), the more confident one wins."""
    hands = {}
    for hand in message.get("hands") or ():
        if not isinstance(hand, dict) or hand.get("type") not in ("left", "right"):
            continue
        side = hand["type"]
        conf = hand.get("confidence", 1.0)
        conf = float(conf) if isinstance(conf, (int, float)) and math.isfinite(conf) else 0.0
        if side in hands and hands[side][1] >= conf:
            continue
        hands[side] = (hand.get("id"), conf, hand)
    by_id = {entry[0]: side for side, entry in hands.items()}
    points: dict = {}
    for side, (_id, _conf, hand) in hands.items():
        for key, joint in (("palmPosition", "palm"), ("wrist", "wrist")):
            p = _vec(hand.get(key))
            if p is not None:
                points[f"{side}.{joint}"] = p
    for finger in message.get("pointables") or ():
        if not isinstance(finger, dict) or finger.get("tool"):
            continue
        side = by_id.get(finger.get("handId"))
        kind = finger.get("type")
        if side is None or not isinstance(kind, int) or not 0 <= kind < len(FINGERS):
            continue
        name = FINGERS[kind]
        for key, joint in _joints(name):
            p = _vec(finger.get(key))
            if p is not None:
                points[f"{side}.{name}.{joint}"] = p
    rate = message.get("currentFrameRate", 0.0)
    return LeapFrame(frame_id=int(message.get("id", 0) or 0), timestamp_us=int(message.get("timestamp", 0) or 0),
                     points=points, confidence={side: entry[1] for side, entry in hands.items()},
                     frame_rate=float(rate) if isinstance(rate, (int, float)) else 0.0)


def version_message(service_version: str = "4.1.0+viestac-emulator") -> dict:
    return {"serviceVersion": service_version, "version": VERSION}


def build_frame(frame_id: int, timestamp_us: int, points: dict, *, confidence: float = 1.0,
                frame_rate: float = NOMINAL_HZ) -> dict:
    """A v6 frame carrying `points` (point name → mm, device frame), as the service would send it:
    one hand per side that has a point, its fingers as pointables. Joints not given are left
    out of a pointable, except `tipPosition`, which a finger always has (a finger with no tip is
    not sent)."""
    sides = sorted({name.split(".", 1)[0] for name in points})
    hands, pointables = [], []
    for h, side in enumerate(sides):
        hand_id = 1 + h
        hand = {"id": hand_id, "type": side, "confidence": confidence, "timeVisible": frame_id / frame_rate,
                "palmNormal": [0.0, -1.0, 0.0], "direction": [0.0, 0.0, -1.0]}
        palm = points.get(f"{side}.palm", points.get(f"{side}.index.tip"))
        hand["palmPosition"] = list(palm) if palm is not None else [0.0, 200.0, 0.0]
        if f"{side}.wrist" in points:
            hand["wrist"] = list(points[f"{side}.wrist"])
        hands.append(hand)
        for kind, finger in enumerate(FINGERS):
            tip = points.get(f"{side}.{finger}.tip")
            if tip is None:
                continue
            entry = {"id": hand_id * 10 + kind, "handId": hand_id, "type": kind, "tool": False, "extended": True,
                     "length": 50.0, "width": 18.0, "direction": [0.0, 0.0, -1.0]}
            for key, joint in _joints(finger):
                p = points.get(f"{side}.{finger}.{joint}")
                if p is not None:
                    entry[key] = list(p)
            if finger == "thumb" and "mcpPosition" in entry:
                entry["carpPosition"] = entry["mcpPosition"]  # the Leap's zero-length thumb metacarpal
            pointables.append(entry)
    return {"id": frame_id, "timestamp": timestamp_us, "currentFrameRate": frame_rate, "hands": hands,
            "pointables": pointables, "gestures": [], "devices": [],
            "interactionBox": {"center": [0.0, 200.0, 0.0], "size": [235.0, 235.0, 147.0]}}
