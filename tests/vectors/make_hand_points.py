"""Writes tests/vectors/hand_points.json: the tracked point names and the bones a hand is drawn
with, from server/core/points.py, so the browser client's own copy (clients/web/src/hand.js) is
tested against the Python owner (clients/web/test/hand.test.mjs) and
tests/test_hand_points_vector.py fails when points.py changes and this file was not rewritten.

Run: .venv/bin/python tests/vectors/make_hand_points.py
"""

import json
from pathlib import Path

from server.core import points

OUT = Path(__file__).parent / "hand_points.json"


def hand_points_data() -> dict:
    return {
        "note": "written by tests/vectors/make_hand_points.py from server/core/points.py",
        "primary": points.PRIMARY_POINT,
        "hands": list(points.HANDS),
        "fingers": list(points.FINGERS),
        "points": list(points.POINT_NAMES),
        "bones": {hand: [list(b) for b in points.bones(hand)] for hand in points.HANDS},
    }


def render() -> str:
    return json.dumps(hand_points_data(), indent=1) + "\n"


if __name__ == "__main__":
    OUT.write_text(render(), encoding="utf-8")
