"""stimulus-v1 (contracts C1): interval timing on the tick clock, blank intervals, the driven
field, every cue kind, refusals naming the field, the requirement following the cue."""

import time
import urllib.error

import pytest

from devices.capability import check
from devices.profiles import profile_by_model
from scenarios.registry import check_scenario_params, create, resolve
from scenarios.stimulus import ID, Stimulus
from server.core.cues import PulseTrain, Stiffness, Temperature, Texture, Tilt, Vibration
from server.core.scenario import ParamError, Trial, required_dimensions
from server.hub.control import ScenarioControl, ScenarioRefused
from server.loop.simulation import Simulation


def trial(phase="main", **params) -> Trial:
    return Trial.parse(Stimulus.TRIAL_PARAMS, phase, params, 0)


def run(scenario: Stimulus, settings: Trial, ticks: int, idle: int = 3):
    """Step a simulation `idle` ticks, set the trial, step `ticks` more: each tick's (tick after
    the trial's first, output)."""
    sim = Simulation(scenario)
    for _ in range(idle):
        sim.step()
    sim.set_trial(settings)
    return [(i, sim.step().output) for i in range(ticks)]


def edges(outputs) -> dict:
    """{(event name, interval): tick} and the ticks on which a cue was emitted."""
    events = {(e["name"], e.get("interval")): i for i, out in outputs for e in out.events}
    on = [i for i, out in outputs if out.cues]
    return events, on


def test_registered_under_its_id():
    assert resolve("stimulus").id == ID == "stimulus-v1"
    assert isinstance(create("stimulus", cue="tilt"), Stimulus)


@pytest.mark.parametrize("lead, duration, isi, n", [(500, 500, 500, 2), (0, 1, 0, 4), (37, 123, 250, 3),
                                                    (100, 60, 40, 1)])
def test_every_interval_on_and_off_at_its_exact_tick(lead, duration, isi, n):
    scenario = create("stimulus", duration_ms=duration, isi_ms=isi, lead_ms=lead)
    levels = {f"level_{k}": 10.0 * k for k in range(1, n + 1)}
    total = lead + n * duration + (n - 1) * isi + 5
    events, on = edges(run(scenario, trial(n_intervals=n, **levels), total))
    expected_on = []
    for k in range(1, n + 1):
        start = lead + (k - 1) * (duration + isi)
        assert events[("interval_on", k)] == start
        assert events[("interval_off", k)] == start + duration
        expected_on += range(start, start + duration)
    assert on == expected_on
    assert len(events) == 2 * n


def test_values_and_hud_follow_the_stages():
    scenario = create("stimulus", duration_ms=3, isi_ms=2, lead_ms=2)
    outputs = run(scenario, trial(n_intervals=2, level_1=50.0, level_2=60.0), 14)
    stages = [(out.values["stage"], out.values["interval"], out.hud) for _, out in outputs]
    assert stages == [("lead", 0, "Get ready")] * 2 + [("interval", 1, "Interval 1")] * 3 + [("isi", 0, "")] * 2 \
        + [("interval", 2, "Interval 2")] * 3 + [("respond", 0, "Answer now")] * 4
    assert all(out.values["n_intervals"] == 2 for _, out in outputs)
    # the scenario never ends a trial itself: the answer does
    assert all(out.finished is None for _, out in outputs)


def test_blank_interval_is_marked_with_no_cue():
    scenario = create("stimulus", duration_ms=10, isi_ms=5, lead_ms=5)
    outputs = run(scenario, trial(n_intervals=2, level_1=None, level_2=80.0), 40)
    events, on = edges(outputs)
    assert events[("interval_on", 1)] == 5 and events[("interval_off", 1)] == 15
    assert [out.hud for i, out in outputs if 5 <= i < 15] == ["Interval 1"] * 10
    assert on == list(range(20, 30))  # only interval 2 presents a cue
    assert outputs[20][1].cues == (Vibration(80.0, None, 10.0),)


def test_duration_as_the_driven_parameter():
    scenario = create("stimulus", duration_ms=500, isi_ms=10, lead_ms=0, intensity_pct=70)
    outputs = run(scenario, trial(parameter="duration_ms", n_intervals=3, level_1=20.0, level_2=5.0, level_3=None),
                  80)
    events, on = edges(outputs)
    assert (events[("interval_on", 1)], events[("interval_off", 1)]) == (0, 20)
    assert (events[("interval_on", 2)], events[("interval_off", 2)]) == (30, 35)
    assert events[("interval_on", 3)] == 45  # blank: marked, with no cue
    assert on == list(range(0, 20)) + list(range(30, 35))
    assert outputs[0][1].cues == (Vibration(70.0, None, 20.0),)
    assert outputs[30][1].cues == (Vibration(70.0, None, 5.0),)


def test_blank_interval_with_duration_driven_lasts_duration_ms():
    scenario = create("stimulus", duration_ms=7, isi_ms=3, lead_ms=0)
    events, _ = edges(run(scenario, trial(parameter="duration_ms", n_intervals=2, level_1=None, level_2=4.0), 30))
    assert events == {("interval_on", 1): 0, ("interval_off", 1): 7, ("interval_on", 2): 10, ("interval_off", 2): 14}


def test_contact_angle_is_shown_as_a_tilt_toward_minus_the_angle():
    scenario = create("stimulus", cue="tilt", magnitude_pct=80, duration_ms=2, isi_ms=1, lead_ms=0)
    outputs = run(scenario, trial(parameter="contact_angle_deg", n_intervals=3, level_1=-90.0, level_2=0.0,
                                  level_3=50.0), 10)
    assert outputs[0][1].cues == (Tilt(90.0, 80.0),)
    assert outputs[3][1].cues == (Tilt(0.0, 80.0),)
    assert outputs[6][1].cues == (Tilt(310.0, 80.0),)


@pytest.mark.parametrize("params, parameter, level, cue", [
    ({"cue": "vibration", "carrier_hz": 250}, "intensity_pct", 30.0, Vibration(30.0, 250.0, 4.0)),
    ({"cue": "vibration", "intensity_pct": 50}, "carrier_hz", 120.0, Vibration(50.0, 120.0, 4.0)),
    ({"cue": "pulse_train", "t_on_ms": 1, "t_off_ms": 1}, "intensity_pct", 40.0, PulseTrain(1.0, 1.0, 40.0, None, 4.0)),
    ({"cue": "texture", "duty": 0.3}, "period_us", 2000.0, Texture(2000.0, 0.3, 100.0)),
    ({"cue": "texture", "period_us": 500}, "intensity_pct", 20.0, Texture(500.0, 0.5, 20.0)),
    ({"cue": "tilt", "magnitude_pct": 60}, "direction_deg", 270.0, Tilt(270.0, 60.0)),
    ({"cue": "tilt", "direction_deg": 90}, "magnitude_pct", 25.0, Tilt(90.0, 25.0)),
    ({"cue": "stiffness"}, "relative", 0.25, Stiffness(relative=0.25)),
    ({"cue": "temperature"}, "celsius", 38.5, Temperature(38.5)),
])
def test_every_cue_kind_with_its_driven_field(params, parameter, level, cue):
    scenario = create("stimulus", duration_ms=4, isi_ms=0, lead_ms=1, **params)
    outputs = run(scenario, trial(parameter=parameter, n_intervals=1, level_1=level), 6)
    assert [out.cues for _, out in outputs] == [()] + [(cue,)] * 4 + [()]


def test_duration_is_carried_on_vibration_and_pulse_cues_only():
    for cue in ("vibration", "pulse_train"):
        outputs = run(create("stimulus", cue=cue, duration_ms=250, lead_ms=0), trial(level_1=90.0), 1)
        assert outputs[0][1].cues[0].duration_ms == 250.0
    outputs = run(create("stimulus", cue="texture", duration_ms=250, lead_ms=0), trial(level_1=90.0), 1)
    assert not hasattr(outputs[0][1].cues[0], "duration_ms")


@pytest.mark.parametrize("params, field", [
    ({"cue": "smell"}, "cue"),
    ({"intensity_pct": 101}, "intensity_pct"),
    ({"carrier_hz": 0}, "carrier_hz"),
    ({"duration_ms": 0}, "duration_ms"),
    ({"isi_ms": -1}, "isi_ms"),
    ({"lead_ms": float("nan")}, "lead_ms"),
    ({"cue": "texture", "duty": 1.5}, "duty"),
    ({"cue": "temperature", "celsius": 60}, "celsius"),
    ({"cue": "tilt", "direction_deg": 361}, "direction_deg"),
    ({"colour": "red"}, "colour"),
    ({"cue": "tilt", "intensity_pct": 50}, "intensity_pct"),  # not a field of a tilt
])
def test_bad_params_are_refused_naming_the_field(params, field):
    with pytest.raises(ParamError, match=field):
        create("stimulus", **params)


@pytest.mark.parametrize("params, settings, field", [
    ({}, {"parameter": "celsius", "level_1": 30.0}, "parameter"),
    ({"cue": "tilt"}, {"parameter": "intensity_pct", "level_1": 30.0}, "parameter"),
    ({}, {"parameter": "intensity_pct", "level_1": 120.0}, "level_1"),
    ({}, {"parameter": "carrier_hz", "n_intervals": 2, "level_1": 100.0, "level_2": 0.5}, "level_2"),
    ({"cue": "tilt"}, {"parameter": "contact_angle_deg", "level_1": 95.0}, "level_1"),
    ({}, {"n_intervals": 1, "level_1": 10.0, "level_3": 10.0}, "level_3"),
    ({}, {"parameter": "duration_ms", "level_1": 0.0}, "level_1"),
])
def test_trials_that_do_not_fit_the_cue_are_refused_naming_the_field(params, settings, field):
    checked = check_scenario_params(resolve("stimulus"), params)
    with pytest.raises(ParamError, match=field):
        Stimulus.check_trial(checked, trial(**settings).params)


@pytest.mark.parametrize("settings, field", [({"n_intervals": 5}, "n_intervals"), ({"n_intervals": 0}, "n_intervals"),
                                             ({"parameter": "volume"}, "parameter"), ({"level_1": "loud"}, "level_1")])
def test_bad_trial_params_are_refused_by_their_declaration(settings, field):
    with pytest.raises(ParamError, match=field):
        trial(**settings)


def test_a_trial_that_reaches_the_scenario_unchecked_presents_nothing_and_says_why():
    scenario = create("stimulus")
    outputs = run(scenario, trial(parameter="celsius", level_1=30.0), 600)
    assert all(out.cues == () for _, out in outputs)
    assert "parameter" in outputs[0][1].hud
    assert [e["name"] for _, out in outputs for e in out.events] == ["trial_refused"]


def test_a_trial_ended_mid_interval_records_the_cut_off():
    sim = Simulation(create("stimulus", duration_ms=10, lead_ms=0))
    sim.set_trial(trial(level_1=50.0))
    assert [e["name"] for e in sim.step().output.events] == ["interval_on"]
    sim.step()
    sim.set_trial(None)
    out = sim.step().output
    assert out.events == ({"name": "interval_off", "interval": 1, "cut": True},) and out.cues == ()


def test_a_new_trial_restarts_the_clock_from_its_first_tick():
    sim = Simulation(create("stimulus", duration_ms=5, isi_ms=5, lead_ms=3))
    sim.set_trial(trial(level_1=50.0))
    for _ in range(20):
        sim.step()
    sim.set_trial(trial(level_1=60.0))
    ticks = [i for i in range(10) if sim.step().output.cues]
    assert ticks == [3, 4, 5, 6, 7]


def test_deterministic_across_runs_and_seeds():
    def trace(seed):
        scenario = create("stimulus", cue="pulse_train", duration_ms=30, isi_ms=20, lead_ms=10)
        scenario.reset(seed)
        outputs = run(scenario, trial(n_intervals=4, level_1=10.0, level_2=None, level_3=30.0, level_4=40.0), 200)
        return [(out.cues, out.hud, out.values, out.events) for _, out in outputs]
    assert trace(0) == trace(0) == trace(7)


def test_snapshot_and_restore_replay_the_same_intervals():
    sim = Simulation(create("stimulus", duration_ms=20, isi_ms=10, lead_ms=5))
    sim.set_trial(trial(n_intervals=2, level_1=30.0, level_2=40.0))
    for _ in range(12):
        sim.step()
    snap = sim.snapshot()
    first = [(r.output.cues, r.output.events) for r in (sim.step() for _ in range(50))]
    sim.restore(snap)
    assert [(r.output.cues, r.output.events) for r in (sim.step() for _ in range(50))] == first


@pytest.mark.parametrize("cue, dimensions", [("vibration", ()), ("pulse_train", ()), ("tilt", ("macro_roughness",)),
                                             ("texture", ("fine_roughness",)), ("stiffness", ("stiffness",)),
                                             ("temperature", ("temperature",))])
def test_the_requirement_follows_the_cue(cue, dimensions):
    params = check_scenario_params(resolve("stimulus"), {"cue": cue})
    assert required_dimensions(Stimulus, params) == dimensions
    assert required_dimensions(Stimulus) == Stimulus.REQUIRES == ()


def test_a_tilt_is_refused_on_a_fingertac_and_accepted_on_a_ferrovibe():
    tilt = required_dimensions(Stimulus, {"cue": "tilt"})
    assert not check(ID, tilt, {"ft": profile_by_model("fingertac")}).ok
    assert check(ID, tilt, {"fv": profile_by_model("ferrovibe")}).ok
    assert check(ID, required_dimensions(Stimulus, {"cue": "vibration"}), {"ft": profile_by_model("fingertac")}).ok


def control(model: str) -> ScenarioControl:
    sent = []
    return ScenarioControl(lambda record: sent.append(record) or True, lambda: {"dev": profile_by_model(model)})


def test_the_hub_refuses_a_tilt_stimulus_where_no_device_shows_tilt():
    with pytest.raises(ScenarioRefused, match="macro-roughness"):
        control("fingertac").switch_scenario("stimulus", {"cue": "tilt"})
    assert control("fingertac").switch_scenario("stimulus", {"cue": "vibration"})["capability"]["ok"]
    assert control("ferrovibe").switch_scenario("stimulus", {"cue": "tilt"})["capability"]["ok"]


def test_the_hub_refuses_a_trial_that_does_not_fit_the_running_cue():
    hub = control("ferrovibe")
    hub.switch_scenario("stimulus", {"cue": "tilt"})
    with pytest.raises(ParamError, match="parameter"):
        hub.set_trial("main", {"parameter": "intensity_pct", "level_1": 50.0})
    with pytest.raises(ParamError, match="level_1"):
        hub.set_trial("main", {"parameter": "contact_angle_deg", "level_1": -120.0})
    assert hub.set_trial("main", {"parameter": "contact_angle_deg", "level_1": -60.0})["params"]["level_1"] == -60.0
    assert hub.requires() == ("macro_roughness",)


# -- through a real server (hub, loop, simulated rig: a FingerTac and a FerroVibe) -------------------

@pytest.fixture(scope="module")
def live():
    from tests.live_server import serve
    yield from serve("stimulus")


def http_error(call) -> tuple[int, str]:
    with pytest.raises(urllib.error.HTTPError) as info:
        call()
    return info.value.code, info.value.read().decode()


def test_live_the_requirement_and_the_trial_checks_follow_the_cue(live):
    # no device of the simulated rig shows temperature: refused, naming the dimension
    code, body = http_error(lambda: live.post("/api/scenario", {"name": "stimulus", "params": {"cue": "temperature"}}))
    assert code == 409 and "temperature" in body
    switched = live.post("/api/scenario", {"name": "stimulus", "params": {"cue": "tilt", "lead_ms": 0}})
    assert switched["capability"]["ok"]
    deadline = time.monotonic() + 10
    while live.get("/api/scenario").get("params", {}).get("cue") != "tilt":
        assert time.monotonic() < deadline, "the switch to a tilt stimulus was never announced"
        time.sleep(0.02)
    code, body = http_error(lambda: live.post("/api/trial", {"phase": "main", "params": {"parameter": "intensity_pct",
                                                                                       "level_1": 50.0}}))
    assert code == 422 and "parameter" in body and "tilt" in body
    code, body = http_error(lambda: live.post("/api/trial", {"phase": "main", "params": {
        "parameter": "contact_angle_deg", "level_1": 120.0}}))
    assert code == 422 and "level_1" in body
    started = live.post("/api/trial", {"phase": "main", "params": {"parameter": "contact_angle_deg", "level_1": 30.0}})
    assert started["trial"]["params"]["level_1"] == 30.0
    deadline = time.monotonic() + 10
    while (live.get("/api/scenario").get("trial") or {}).get("params", {}).get("level_1") != 30.0:
        assert time.monotonic() < deadline, "the trial was never announced"
        time.sleep(0.02)
    live.delete("/api/trial")
