"""Tracked point names: the WebXR joint set, both ways."""

import pytest

from server.core import points

WEBXR_JOINTS = (  # W3C WebXR Hand Input, XRHandJoint enum, in its order
    "wrist",
    "thumb-metacarpal", "thumb-phalanx-proximal", "thumb-phalanx-distal", "thumb-tip",
    *(f"{f}-finger-{j}" for f in ("index", "middle", "ring", "pinky")
      for j in ("metacarpal", "phalanx-proximal", "phalanx-intermediate", "phalanx-distal", "tip")),
)


def test_every_webxr_joint_has_one_point_and_back():
    assert len(WEBXR_JOINTS) == 25
    for hand in points.HANDS:
        names = [points.point_from_webxr(hand, joint) for joint in WEBXR_JOINTS]
        assert None not in names and len(set(names)) == 25
        assert [points.point_to_webxr(n) for n in names] == [(hand, j) for j in WEBXR_JOINTS]


def test_names_are_the_joints_plus_palm():
    assert len(points.POINT_NAMES) == 2 * 26
    assert points.point_to_webxr("left.palm") is None
    assert points.point_from_webxr("right", "index-finger-tip") == "right.index.tip" == points.PRIMARY_POINT
    assert points.point_from_webxr("right", "thumb-phalanx-intermediate") is None
    assert points.point_from_webxr("middle", "wrist") is None


@pytest.mark.parametrize("bad", ["right.index", "right.thumb.intermediate", "RIGHT.index.tip", "", 3, None])
def test_a_bad_name_is_refused_with_the_scheme(bad):
    assert not points.is_point_name(bad)
    with pytest.raises(ValueError, match="HAND.FINGER.JOINT"):
        points.check_point_name(bad)


def test_bones_connect_every_joint_of_a_hand_to_the_wrist():
    segments = points.bones("right")
    assert len(segments) == 24  # one bone below each of the 24 finger joints
    reached = {"right.wrist"} | {b for _, b in segments}
    assert reached == set(points.hand_points("right")) - {"right.palm"}
