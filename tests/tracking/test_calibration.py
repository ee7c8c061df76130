import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from server.tracking.calibration import Calibration, fit, hold_still, leap_default


def random_calibration(seed):
    rng = np.random.default_rng(seed)
    r = Rotation.random(random_state=seed).as_matrix()
    return Calibration(rotation=tuple(map(tuple, r)), scale=float(rng.uniform(0.001, 2.0)),
                       offset=tuple(rng.normal(0, 1, 3)))


@pytest.mark.parametrize("seed", range(5))
def test_round_trip_fit_recovers_the_transform(seed):
    truth = random_calibration(seed)
    rng = np.random.default_rng(100 + seed)
    src = rng.normal(0, 100, (4, 3))
    dst = [truth.apply(p) for p in src]
    got = fit(src, dst)
    assert np.allclose(got.rotation, truth.rotation, atol=1e-9)
    assert got.scale == pytest.approx(truth.scale, rel=1e-9)
    assert np.allclose(got.offset, truth.offset, atol=1e-9)
    assert got.residual < 1e-9
    for p in rng.normal(0, 100, (10, 3)):
        assert np.allclose(got.invert(got.apply(p)), p, atol=1e-9)
    back = Calibration.from_dict(got.to_dict())
    assert back.apply(src[0]) == got.apply(src[0])


def test_noisy_points_give_a_residual_and_a_proper_rotation():
    truth = leap_default()
    rng = np.random.default_rng(3)
    src = rng.normal(0, 80, (6, 3)) + [0, 200, 0]
    dst = np.array([truth.apply(p) for p in src]) + rng.normal(0, 0.002, (6, 3))
    got = fit(src, dst, units="mm")
    assert np.linalg.det(np.array(got.rotation)) == pytest.approx(1.0)
    assert 0 < got.residual < 0.005
    assert got.scale == pytest.approx(0.005, rel=0.02)


def test_mirrored_points_still_give_a_rotation():
    src = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    dst = src * [1, 1, -1]  # a reflection: no rotation fits exactly
    got = fit(src, dst)
    assert np.linalg.det(np.array(got.rotation)) == pytest.approx(1.0)
    assert got.residual > 0.1


def test_collinear_points_refused():
    with pytest.raises(ValueError, match="one line"):
        fit([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 0, 0], [1, 0, 0], [2, 0, 0]])
    with pytest.raises(ValueError):
        fit([[0, 0, 0], [1, 0, 0]], [[0, 0, 0], [1, 0, 0]])


def test_hold_still_moves_only_the_offset():
    cal = leap_default()
    held = (12.0, 180.0, -7.0)
    ref = (0.0, 0.0, 0.7)
    got = hold_still(cal, held, ref)
    assert np.allclose(got.apply(held), ref, atol=1e-12)
    assert got.rotation == cal.rotation and got.scale == cal.scale


def test_leap_axes_map_up_to_scene_z():
    cal = leap_default()
    a, b = np.array(cal.apply((0, 100, 0))), np.array(cal.apply((0, 200, 0)))
    assert np.allclose(b - a, [0, 0, 0.5])
    a, b = np.array(cal.apply((0, 200, 0))), np.array(cal.apply((100, 200, 0)))
    assert np.allclose(b - a, [0, 0.5, 0])  # Leap right = scene +y (right on the default camera)


def test_not_a_rotation_refused():
    with pytest.raises(ValueError):
        Calibration(rotation=((1, 0, 0), (0, 1, 0), (0, 0, -1)))
