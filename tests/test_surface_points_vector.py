"""The surface-point vector file the browser client tests against is what
server/core/haptics/primitives.py says now, and it covers every primitive from inside and out."""

from server.core.haptics.primitives import SHAPE_TYPES
from tests.vectors.make_surface_points import OUT, render, surface_points_data


def test_the_checked_in_surface_points_vector_is_current():
    assert OUT.read_text(encoding="utf-8") == render(), "run tests/vectors/make_surface_points.py"


def test_every_primitive_is_covered_inside_and_outside_at_every_pose():
    data = surface_points_data()
    assert data["types"] == sorted(SHAPE_TYPES)
    for t in SHAPE_TYPES:
        cases = [c for c in data["cases"] if c["shape"]["type"] == t]
        assert len(cases) == 3, t
        for c in cases:
            sds = [r["sd"] for r in c["points"]]
            assert min(sds) < 0 < max(sds), (t, c["pose"])
