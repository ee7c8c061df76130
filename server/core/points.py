"""Names of tracked points: one scheme for every tracker, tool, rig file and client.

A name is `HAND.wrist`, `HAND.palm` or `HAND.FINGER.JOINT`, e.g. `right.index.tip`. The joints
follow the WebXR Hand Input joint set (W3C WebXR Hand Input Module, "Skeleton joints": 25 joints
per hand), shortened: `index-finger-phalanx-distal` is `index.distal`, `thumb-tip` is
`thumb.tip`. A joint names the point at the *base* of its bone, as in WebXR (`index.distal` is
the distal interphalangeal joint, `index.tip` the fingertip). The thumb has no intermediate
phalanx. `palm` is not a WebXR joint (OpenXR's XR_HAND_JOINT_PALM_EXT is): trackers that report a
palm centre (Leap Motion's `palmPosition`) use it.

Pure: no I/O.
"""

from __future__ import annotations

HANDS = ("left", "right")
FINGERS = ("thumb", "index", "middle", "ring", "pinky")
FINGER_JOINTS = ("metacarpal", "proximal", "intermediate", "distal", "tip")
THUMB_JOINTS = ("metacarpal", "proximal", "distal", "tip")

PRIMARY_POINT = "right.index.tip"  # the HIP: the point a single-point tracker (a mouse) drives

_WEBXR_FINGER = {"thumb": "thumb", "index": "index-finger", "middle": "middle-finger", "ring": "ring-finger",
                 "pinky": "pinky-finger"}
_WEBXR_JOINT = {"metacarpal": "metacarpal", "proximal": "phalanx-proximal", "intermediate": "phalanx-intermediate",
                "distal": "phalanx-distal", "tip": "tip"}


def finger_joints(finger: str) -> tuple[str, ...]:
    return THUMB_JOINTS if finger == "thumb" else FINGER_JOINTS


def hand_points(hand: str) -> tuple[str, ...]:
    """Every point name of one hand: wrist, palm, then each finger from base to tip."""
    return (f"{hand}.wrist", f"{hand}.palm") + tuple(
        f"{hand}.{finger}.{joint}" for finger in FINGERS for joint in finger_joints(finger))


POINT_NAMES: tuple[str, ...] = hand_points("left") + hand_points("right")
_POINT_SET = frozenset(POINT_NAMES)


def is_point_name(name: object) -> bool:
    return isinstance(name, str) and name in _POINT_SET


def check_point_name(name: object) -> str:
    """`name` if it is a point name; ValueError saying what a name looks like otherwise."""
    if not is_point_name(name):
        raise ValueError(f"{name!r} is not a tracked point name; expected HAND.wrist, HAND.palm or "
                         f"HAND.FINGER.JOINT with HAND in {HANDS}, FINGER in {FINGERS}, JOINT in "
                         f"{FINGER_JOINTS} (the thumb has no intermediate), e.g. {PRIMARY_POINT!r}")
    return name  # type: ignore[return-value]


def point_from_webxr(handedness: str, joint: str) -> str | None:
    """The point name of a WebXR XRHand joint ('index-finger-tip' of the 'right' hand →
    'right.index.tip'); None for a joint name WebXR does not define."""
    if handedness not in HANDS:
        return None
    if joint == "wrist":
        return f"{handedness}.wrist"
    for finger, prefix in _WEBXR_FINGER.items():
        for ours, theirs in _WEBXR_JOINT.items():
            if joint == f"{prefix}-{theirs}" and ours in finger_joints(finger):
                return f"{handedness}.{finger}.{ours}"
    return None


def point_to_webxr(name: str) -> tuple[str, str] | None:
    """(handedness, WebXR joint name) of a point; None for the palm, which WebXR lacks."""
    parts = check_point_name(name).split(".")
    if parts[1] == "palm":
        return None
    if parts[1] == "wrist":
        return parts[0], "wrist"
    return parts[0], f"{_WEBXR_FINGER[parts[1]]}-{_WEBXR_JOINT[parts[2]]}"


def bones(hand: str) -> tuple[tuple[str, str], ...]:
    """The segments a hand is drawn with: wrist → each finger's base, then joint to joint."""
    segments = []
    for finger in FINGERS:
        chain = (f"{hand}.wrist",) + tuple(f"{hand}.{finger}.{joint}" for joint in finger_joints(finger))
        segments.extend(zip(chain, chain[1:]))
    return tuple(segments)
