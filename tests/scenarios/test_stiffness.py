"""Scenario 3 (thesis §4.1.3): levels, spring constants, the pulse-train encoding of every
level, keys for estimation and production, recording with the left sphere hidden."""

import pytest

from server.core.cues import Stiffness
from devices.encoder import CueEncoder
from devices.messages import PatternMode
from devices.profiles import FERROVIBE, FINGERTAC
from server.core.scenario import Trial
from scenarios.stiffness import LEFT, MIDDLE, RIGHT, SPACING, StiffnessScenario, level_cue, level_k
from server.loop.simulation import Simulation
from tests.scenarios.driving import finished, metrics_of

# docs/devices.md: rate = L Hz (1 Hz at level 1 … 10 Hz at level 10), t_on 50 ms, t_off = 1000/rate − 50 ms
T_OFF_MS = {1: 950.0, 2: 450.0, 3: 283.333, 4: 200.0, 5: 150.0, 6: 116.667, 7: 92.857, 8: 75.0, 9: 61.111, 10: 50.0}


def test_spring_constants_of_the_levels():
    assert [level_k(level) for level in range(1, 11)] == [1, 20, 30, 40, 50, 60, 70, 80, 90, 100]
    with pytest.raises(ValueError):
        level_k(11)


@pytest.mark.parametrize("level", range(1, 11))
@pytest.mark.parametrize("profile", [FINGERTAC, FERROVIBE])
def test_level_to_t_off_through_the_encoder(level, profile):
    encoding = CueEncoder(profile).encode((level_cue(level),))
    assert encoding.refusals == ()
    pattern = encoding.commands["pattern"]
    assert pattern.mode == PatternMode.PULSE and pattern.intensity == 100
    assert pattern.on_us == 50_000
    assert pattern.off_us == pytest.approx(T_OFF_MS[level] * 1000, abs=1)


def _tap(sim, sphere_y, n=40):
    sim.set_hip((0.0, sphere_y, 0.8 + 0.06 - 0.02))  # 2 cm into the top of the sphere
    return [sim.step() for _ in range(n)]


@pytest.mark.parametrize("sphere, y, level", [(LEFT, -SPACING, 1), (MIDDLE, 0.0, 5), (RIGHT, SPACING, 10)])
def test_tapping_a_sphere_emits_its_stiffness_and_spring_force(sphere, y, level):
    sim = Simulation(StiffnessScenario(middle_level=5))
    last = _tap(sim, y)[-1]
    assert last.output.cues == (Stiffness(level_k(level), (level - 1) / 9),)
    assert last.output.values["touching"] == sphere
    assert last.force[2] == pytest.approx(level_k(level) * 0.02, rel=1e-6)  # F = k · penetration


def test_random_key_and_production_keys_with_every_press_recorded():
    sim = Simulation(StiffnessScenario(), seed=7)
    sim.set_trial(Trial.parse(StiffnessScenario.TRIAL_PARAMS, "main",
                              {"mode": "production", "level": 4, "start_level": 10}))
    sim.step()
    sim.input("r", "press")
    for key in ("ArrowDown", "ArrowDown", "ArrowDown", "ArrowUp"):
        sim.input(key, "down")
        sim.step()
    sim.input("ArrowDown", "up")  # key releases are not presses
    last = _tap(sim, SPACING, 40)[-1]
    assert last.output.cues == (level_cue(8),) and last.force[2] == pytest.approx(80 * 0.02, rel=1e-6)
    keys = [e for e in sim.data.events if e["name"] == "key"]
    assert [(e["key"], e["right_level"]) for e in keys] == [("ArrowDown", 9), ("ArrowDown", 8), ("ArrowDown", 7),
                                                             ("ArrowUp", 8)]
    assert [e["tick"] for e in keys] == sorted(e["tick"] for e in keys) and all("t" in e for e in keys)
    sim.input("r", "press")
    done = sim.step()
    assert done.output.values["produced_level"] == 8 and done.output.values["match_time_s"] > 0


def test_recording_hides_the_left_sphere_and_makes_it_untouchable():
    sim = Simulation(StiffnessScenario())
    sim.input("r", "press")
    sim.step()
    assert sim.data.visibility[LEFT] is False and sim.data.visibility["left_label"] is False
    assert LEFT in sim.data.untouchable
    assert _tap(sim, -SPACING)[-1].output.cues == ()
    sim.input("r", "press")
    sim.step()
    assert sim.data.visibility[LEFT] is True and LEFT not in sim.data.untouchable


def test_estimation_keeps_the_right_reference_and_the_n_key_draws_from_the_seed():
    sim = Simulation(StiffnessScenario(), seed=3)
    sim.set_trial(Trial.parse(StiffnessScenario.TRIAL_PARAMS, "main", {"mode": "estimation", "level": 6}))
    sim.input("ArrowDown", "down")
    last = _tap(sim, SPACING)[-1]
    assert last.output.cues == (level_cue(10),) and last.output.values["right_level"] == 10
    assert "1-10" in last.output.hud
    draws = []
    for seed in (3, 3, 4):
        s = Simulation(StiffnessScenario(), seed=seed)
        for _ in range(5):
            s.input("n", "press")
        s.step()
        draws.append(s.scenario.levels[MIDDLE])
    assert draws[0] == draws[1]


def test_study_design():
    estimation, production = StiffnessScenario.SUBTASKS
    assert [c["level"] for c in estimation.conditions] == list(range(1, 11))
    assert [c["level"] for c in production.conditions] == list(range(1, 11))
    assert estimation.answer.low == 1 and estimation.answer.high == 10


def test_a_production_trial_reports_its_result_when_recording_stops():
    sim = Simulation(StiffnessScenario())
    sim.set_trial(Trial.parse(StiffnessScenario.TRIAL_PARAMS, "main", {"mode": "production", "level": 4}))
    results = [sim.step()]
    start = sim.scenario.levels[RIGHT]
    sim.input("r", "press")
    for _ in range(500):
        results.append(sim.step())
    sim.input("ArrowDown", "down")
    results.append(sim.step())
    sim.input("r", "press")
    results.append(sim.step())
    done = [e for e in sim.data.events if e["name"] == "trial_done"]
    assert len(done) == 1
    assert done[0]["produced_level"] == start - 1 and done[0]["target_level"] == 4
    assert done[0]["match_time_s"] == pytest.approx(0.501, abs=1e-9)  # pressed after tick 0, again after tick 501
    assert finished(results) == [(done[0]["tick"], metrics_of(done[0]))], "the result is the step's `finished` too"
