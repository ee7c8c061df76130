"""Scenario control (server/hub/control.py), without a web server: the checks of commands, switches
and trials, the records they send, and nothing sent when a check fails or the mailbox is full."""

import pytest

from devices.profiles import profile_by_model
from scenarios.contact_angle import ContactAngle
from scenarios.registry import UnknownScenario
from server.core.scenario import ParamError
from server.hub.control import BusyError, ScenarioControl, ScenarioRefused
from server.ipc.records import Input, SwitchScenario, Trial


def control(profiles=("ferrovibe",), accept=True):
    sent = []
    ctl = ScenarioControl(lambda record: accept and (sent.append(record) or True),
                          lambda: {model: profile_by_model(model) for model in profiles})
    ctl.scenario_cls = ContactAngle
    return ctl, sent


def test_commands_are_checked_for_role_and_value_before_they_are_sent():
    ctl, sent = control()
    ctl.command("tap_angle", "press", 30, role="operator", client_id=4)
    assert sent == [Input(4, "tap_angle", "press", 30.0)], "the value in its declared form"
    with pytest.raises(PermissionError, match="experimenter command"):
        ctl.command("tap_angle", "press", 30, role="participant")
    with pytest.raises(ParamError, match="needs a value"):
        ctl.command("tap_angle", "press")
    with pytest.raises(ParamError, match="must be in"):
        ctl.command("tap_angle", "press", 120)
    with pytest.raises(ParamError, match="takes no value"):
        ctl.command("release", "press", 1)
    with pytest.raises(ParamError, match="no command 'x' that takes a value"):
        ctl.command("x", "press", 1)
    ctl.command("x", "down", role="participant")  # an undeclared key passes (keyboards send every key)
    assert sent[1:] == [Input(0, "x", "down")]


def test_a_full_mailbox_is_busy_and_changes_nothing():
    ctl, _ = control(accept=False)
    with pytest.raises(BusyError):
        ctl.command("release", "press")
    with pytest.raises(BusyError):
        ctl.switch_scenario("stiffness", force=True)
    assert ctl.scenario_cls is ContactAngle, "a switch that was not sent is not the running scenario"
    with pytest.raises(BusyError):
        ctl.set_trial(None)


def test_switches_check_the_name_the_parameters_and_the_devices():
    ctl, sent = control(profiles=("fingertac",))
    with pytest.raises(UnknownScenario, match="did you mean"):
        ctl.switch_scenario("stifness")
    with pytest.raises(ParamError, match="middle_level"):
        ctl.switch_scenario("stiffness", {"middle_level": 11})
    with pytest.raises(ScenarioRefused) as refused:
        ctl.switch_scenario("contact-angle")  # tilt: the FingerTac shows no macro roughness
    assert not refused.value.report.ok and sent == []
    forced = ctl.switch_scenario("contact-angle", {"magnitude_pct": 50}, seed=3, force=True)
    assert sent == [SwitchScenario("contact-angle-v1", forced["params"], 3, 1)] and forced["params"]["magnitude_pct"] == 50.0
    info = ctl.switch_scenario("stiffness", {"middle_level": 4}, seed=1)
    assert info["capability"]["ok"] and sent[-1] == SwitchScenario("stiffness-v1", {"middle_level": 4, "labels": True}, 1, 2)
    with pytest.raises(ParamError, match="mode"):  # trials are checked against the new scenario at once
        ctl.set_trial("main", {"angle_deg": 10})


def test_trials_are_parsed_against_the_running_scenario():
    ctl, sent = control()
    assert ctl.set_trial("main", {"angle_deg": -50}, 2) == {"phase": "main", "index": 2,
                                                            "params": {"angle_deg": -50.0, "time_limit_s": 30.0}}
    assert ctl.set_trial(None) is None
    assert sent == [Trial({"phase": "main", "index": 2, "params": {"angle_deg": -50.0, "time_limit_s": 30.0}}),
                    Trial(None)]
    with pytest.raises(ParamError, match="phase"):
        ctl.set_trial("warmup", {"angle_deg": 0})
    ctl.scenario_cls = None
    with pytest.raises(ParamError, match="no scenario is running yet"):
        ctl.set_trial("main", {"angle_deg": 0})


def test_what_the_loop_announces_is_the_running_scenario():
    ctl, _ = control()
    assert ctl.info("") == {}
    state = {"id": "stiffness-v1", "params": {"middle_level": 5, "labels": True}, "seed": 0, "trial": None, "tick": 9}
    ctl.announced(state)
    info = ctl.info("abc")
    assert info["id"] == "stiffness-v1" and info["scene"] == "abc" and info["info"]["id"] == "stiffness-v1"
    assert "capability" in info


def test_an_announcement_written_before_the_loop_read_a_switch_does_not_undo_it():
    ctl, sent = control(profiles=("ferrovibe", "fingertac"))
    ctl.announced({"id": "stiffness-v1"})
    ctl.switch_scenario("contact-angle")
    ctl.announced({"id": "stiffness-v1", "trial": None})  # the end of the last trial, written before the switch
    assert ctl.set_trial("main", {"angle_deg": 10})["params"]["angle_deg"] == 10, "the trial is for contact-angle"
    ctl.announced({"id": "contact-angle-v1", "switch": 1})
    assert ctl.scenario_cls is ContactAngle

    ctl.switch_scenario("stiffness")
    ctl.switch_scenario("texture")  # supersedes stiffness before its build: the loop announces texture only
    ctl.announced({"id": "contact-angle-v1", "switch": 1})
    assert ctl.scenario_cls.id == "texture-v1"
    ctl.announced({"id": "texture-v1", "switch": 3})
    ctl.announced({"id": "texture-v1", "trial": None, "switch": 3})
    assert ctl.scenario_cls.id == "texture-v1"

    ctl.switch_scenario("stiffness")
    ctl.announced({"id": "texture-v1", "failed": "stiffness-v1", "switch": 4})  # its build failed: texture goes on
    assert ctl.scenario_cls.id == "texture-v1"
    ctl.switch_scenario("stiffness")
    ctl.loop_restarted()  # the new loop runs what it was started with
    ctl.announced({"id": "texture-v1"})
    assert ctl.scenario_cls.id == "texture-v1"


def test_the_target_is_the_last_switch_sent_until_the_loop_announces_it():
    ctl, _ = control()
    announced = {"id": "contact-angle-v1", "params": {}, "seed": 0}
    ctl.announced(announced)
    assert ctl.target() is announced
    ctl.switch_scenario("stiffness", {"middle_level": 3}, seed=4)
    assert ctl.target() == {"id": "stiffness-v1", "params": {"middle_level": 3, "labels": True}, "seed": 4}
    later = {"id": "stiffness-v1", "params": {"middle_level": 3, "labels": True}, "seed": 4, "switch": 1}
    ctl.announced(later)
    assert ctl.target() is later
