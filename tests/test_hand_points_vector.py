"""The hand vector file the browser client tests against is what server/core/points.py says now."""

from tests.vectors.make_hand_points import OUT, hand_points_data, render


def test_the_checked_in_hand_points_vector_is_current():
    assert OUT.read_text(encoding="utf-8") == render(), "run tests/vectors/make_hand_points.py"


def test_every_bone_joins_two_points_of_one_hand():
    data = hand_points_data()
    names = set(data["points"])
    for hand, segments in data["bones"].items():
        assert len(segments) == 24  # 5 fingers: wrist → base, then joint to joint (the thumb has one joint less)
        assert all(a in names and b in names and a.startswith(hand + ".") and b.startswith(hand + ".")
                   for a, b in segments)
