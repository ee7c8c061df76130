"""The number check every validator shares (server/core/numbers.py), and that each site using it
still refuses with its own error type and message: a bool, NaN, infinity and an int too long
for a float are not numbers anywhere."""

import math

import pytest

from devices.link import LinkBudget
from devices.messages import MessageError, SetPattern
from server.bench.force_device import ForceDevice
from server.core.cues import Tilt
from server.core.haptics.contact_gate import ContactGate
from server.core.haptics.pose import Pose
from server.core.numbers import is_finite_number, is_number
from server.core.scenario import Param, ParamError
from server.core.scene import Camera, SceneError, Skin
from server.experiment.export import DEFAULT_TICK_HZ, session_tick_hz
from server.experiment.question import as_number

HUGE = 10 ** 400  # a valid JSON number that no float holds


def test_a_number_is_an_int_or_a_float_but_not_a_bool():
    assert all(is_number(v) for v in (0, -3, 2.5, -0.0, math.inf, math.nan, HUGE))
    assert not any(is_number(v) for v in (True, False, "1", None, [1.0], 1j))


def test_a_finite_number_is_neither_nan_nor_infinite_and_fits_a_float():
    assert all(is_finite_number(v) for v in (0, -3, 2.5, 1e308, 10 ** 300, -(2 ** 63)))
    assert not any(is_finite_number(v) for v in (math.nan, math.inf, -math.inf, HUGE, True, False, "2", None))


SITES = {  # name: (what is checked, the site's error type, its message)
    "param": (lambda v: Param("v", "number", "").check(v), ParamError, r"^v must be a finite number"),
    "scene_number": (lambda v: Camera.from_dict({"height": v}), SceneError,
                     r"^camera\.height must be a finite number$"),
    "scene_vector": (lambda v: Camera.from_dict({"up": [0, 0, v]}), SceneError,
                     r"^camera\.up must be an array of 3 finite numbers$"),
    "skin_tile": (lambda v: Skin("/skins/cork.svg", (v, 0.5)), SceneError, r"^skin tile must be two numbers > 0$"),
    "contact_gate": (lambda v: ContactGate(band=v), ValueError, r"^band must be a finite number >= 0"),
    "cue_range": (lambda v: Tilt(magnitude_pct=v), ValueError, r"^Tilt\.magnitude_pct must be in \[0\.0, 100\.0\]"),
    "device_round": (lambda v: SetPattern.texture(0, v, 0.5, 100.0), MessageError,
                     r"^period_us must be a finite number"),
    "device_duty": (lambda v: SetPattern.texture(0, 4000.0, v, 100.0), MessageError, r"^duty must be in \[0, 1\]"),
    "link_budget": (lambda v: LinkBudget(byte_time_s=v), ValueError, r"^byte_time_s must be > 0"),
    "force_device": (lambda v: ForceDevice(mass_kg=v), ValueError, r"^mass_kg must be a finite number > 0"),
}


@pytest.mark.parametrize("value", [True, math.nan, math.inf, HUGE], ids=["bool", "nan", "inf", "huge"])
@pytest.mark.parametrize("site", list(SITES))
def test_every_site_refuses_a_non_number_with_its_own_error(site, value):
    check, error, message = SITES[site]
    with pytest.raises(error, match=message):
        check(value)


@pytest.mark.parametrize("value", [True, math.nan, math.inf, HUGE], ids=["bool", "nan", "inf", "huge"])
def test_pose_says_whether_a_coordinate_is_no_number_or_not_finite(value):
    with pytest.raises(ValueError, match=r"pose\.pos\[0\] must be " + ("a number" if value is True else "finite")):
        Pose((value, 0.0, 0.0))


def test_lenient_sites_fall_back_instead():
    assert as_number(True) is None and as_number(math.nan) is None and as_number(HUGE) is None
    assert as_number(" 2.5 ") == 2.5 and as_number(3) == 3
    assert session_tick_hz({"tick_hz": True}) == DEFAULT_TICK_HZ and session_tick_hz({"tick_hz": 500}) == 500.0
