"""The scenario declarations: parameter checks, the registry, and what every scenario declares."""

import json

import pytest

from devices.capability import check
from devices.profiles import FERROVIBE, FINGERTAC
from server.core.haptics.primitives import Pose
from server.core.scenario import PHASES, Param, ParamError, Pending, Trial, check_params, describe
from scenarios.registry import SCENARIOS, create

TACTILE_PROPERTY = ("contact-angle-v1", "texture-v1", "stiffness-v1", "shape-v1", "friction-temperature-v1")


def test_param_kinds_convert_and_refuse_with_the_name():
    assert Param("n", "int", "", 1, 1, 10).check(3.0) == 3
    assert Param("p", "choice", "", choices=(2000.0, 3000.0)).check(3000) == 3000.0
    with pytest.raises(ParamError, match=r"x\.n must be a whole number"):
        Param("n", "int", "", 1, 1, 10).check(2.5, "x")
    with pytest.raises(ParamError, match=r"n must be in \[1, 10\]"):
        Param("n", "int", "", 1, 1, 10).check(11)
    with pytest.raises(ParamError, match="finite"):
        Param("v", "number", "").check(float("nan"))
    with pytest.raises(ParamError, match="true or false"):
        Param("b", "bool", "").check(1)
    with pytest.raises(ParamError, match="one of"):
        Param("c", "choice", "", choices=("a", "b")).check(True)


def test_pending_goes_out_once_in_the_next_output_and_a_trial_end_is_both_finished_and_an_event():
    pending = Pending()
    pending.emit("tap", angle_deg=30.0, by="experimenter")
    pending.poses["cube"] = Pose((1.0, 2.0, 3.0))
    pending.visible["arrow"] = False
    pending.touchable["cube"] = False
    pending.stiffness["sphere"] = 40.0
    pending.scales["hole"] = (1.5, 1.5, 1.0)
    pending.finish({"completion_s": 1.25, "object": "cube"})
    out = pending.flush(hud="Done", values={"phase": "done"}, held="cube")
    assert out.events == ({"name": "tap", "angle_deg": 30.0, "by": "experimenter"},
                          {"name": "trial_done", "completion_s": 1.25, "object": "cube"})
    assert out.finished == {"completion_s": 1.25, "object": "cube"}
    assert (out.poses, out.visible, out.touchable) == ({"cube": Pose((1.0, 2.0, 3.0))}, {"arrow": False}, {"cube": False})
    assert (out.stiffness, out.scales) == ({"sphere": 40.0}, {"hole": (1.5, 1.5, 1.0)})
    assert (out.hud, out.values, out.held) == ("Done", {"phase": "done"}, "cube")
    again = pending.flush(hud="")
    assert again.events == () and again.finished is None
    assert not (again.poses or again.visible or again.touchable or again.stiffness or again.scales)
    assert out.poses == {"cube": Pose((1.0, 2.0, 3.0))}, "a flushed output keeps what it carried"


def test_check_params_fills_defaults_and_names_unknown_and_missing():
    specs = (Param("a", "number", "", 1.0), Param("b", "int", "the b", None), Param("c", "text", "", None, optional=True))
    assert check_params(specs, {"b": 2}, "s") == {"a": 1.0, "b": 2, "c": None}
    with pytest.raises(ParamError, match="unknown parameter.*zz; allowed: a, b, c"):
        check_params(specs, {"b": 2, "zz": 1}, "s")
    with pytest.raises(ParamError, match="parameter b is required \\(the b\\)"):
        check_params(specs, {}, "s")


def test_trial_phase_and_index_are_checked():
    assert PHASES == ("training", "trial", "main")
    with pytest.raises(ParamError, match="phase must be one of"):
        Trial.parse((), "warmup", {})
    with pytest.raises(ParamError, match="index"):
        Trial.parse((), "main", {}, index=-1)


@pytest.mark.parametrize("sid", list(SCENARIOS))
def test_every_scenario_declares_json_ready_data_and_valid_conditions(sid):
    cls = SCENARIOS[sid].factory
    data = describe(cls)
    json.dumps(data, allow_nan=False)  # REST and the console get it as JSON
    if sid in TACTILE_PROPERTY:
        assert data["requires"], "every tactile-property scenario is about at least one dimension"
    for sub in cls.SUBTASKS:
        for condition in sub.conditions:
            Trial.parse(cls.TRIAL_PARAMS, "main", condition)  # every study condition is a valid trial
    for control in cls.CONTROLS:
        assert control.who in ("participant", "operator")
    create(sid)


def test_unknown_constructor_parameters_are_refused_before_construction():
    with pytest.raises(ParamError, match="unknown parameter.*colour"):
        create("stiffness", colour="blue")


@pytest.mark.parametrize("sid, fingertac, ferrovibe", [
    ("contact-angle-v1", False, True), ("texture-v1", True, True), ("stiffness-v1", True, True),
    ("shape-v1", False, True), ("friction-temperature-v1", False, False),
])
def test_which_device_can_run_which_scenario(sid, fingertac, ferrovibe):
    cls = SCENARIOS[sid].factory
    assert check(sid, cls.REQUIRES, {"t": FINGERTAC}).ok is fingertac
    assert check(sid, cls.REQUIRES, {"f": FERROVIBE}).ok is ferrovibe
    assert check(sid, cls.REQUIRES, {}).ok, "no device configured: a visual-only run is allowed"
