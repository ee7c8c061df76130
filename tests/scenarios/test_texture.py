"""Scenario 2 (thesis §4.1.2): five periods, a plane moving at a fixed velocity, pairs and
identification with labels only in training."""

import pytest

from server.core.cues import Texture
from server.core.scenario import ParamError, Trial
from scenarios.texture import PERIODS_US, PLANE_ID, WRAP, TextureScenario, frequency_hz, texture_name
from server.loop.simulation import Simulation

ON_PLANE = (0.0, 0.2, 0.03)  # pressing 3 cm into the plane (proxy radius 0.06)


def touching(sim, n):
    sim.set_hip(ON_PLANE)
    return [sim.step() for _ in range(n)]


def test_five_periods_are_the_thesis_frequencies():
    assert PERIODS_US == (2000, 3000, 4000, 5000, 6000)
    assert [round(frequency_hz(p), 2) for p in PERIODS_US] == [500.0, 333.33, 250.0, 200.0, 166.67]
    assert texture_name(6000) == "166.67 Hz (roughest)" and texture_name(2000) == "500 Hz (smoothest)"


@pytest.mark.parametrize("period", PERIODS_US)
def test_texture_plays_while_in_contact_at_half_duty(period):
    sim = Simulation(TextureScenario(period_us=period))
    results = touching(sim, 50)
    assert results[-1].contact
    assert results[-1].output.cues == (Texture(period, 0.5, 100.0),)
    sim.set_hip((0.0, 0.2, 1.0))
    assert [sim.step() for _ in range(100)][-1].output.cues == ()


@pytest.mark.parametrize("velocity", [0.1, -0.25])
def test_plane_moves_at_the_fixed_velocity_only_while_touched(velocity):
    sim = Simulation(TextureScenario(velocity=velocity), tick_hz=1000)
    results = touching(sim, 2001)
    first = next(i for i, r in enumerate(results) if PLANE_ID in r.output.poses)
    y0 = results[first].output.poses[PLANE_ID].pos[1]
    y1 = results[-1].output.poses[PLANE_ID].pos[1]
    ticks = len(results) - 1 - first
    assert (y1 - y0) / (ticks / 1000) == pytest.approx(velocity, rel=1e-9)
    assert sim.data.moved[PLANE_ID].pos[1] == pytest.approx(y1)
    sim.set_hip((0.0, 0.2, 1.0))
    after = [sim.step() for _ in range(200)]
    assert all(PLANE_ID not in r.output.poses for r in after[50:]), "the plane stops when the HIP leaves"


def test_plane_wraps_back_so_the_hip_never_runs_off_the_edge():
    sim = Simulation(TextureScenario(velocity=2.0), tick_hz=1000)
    offsets = [r.output.values["plane_offset"] for r in touching(sim, 1500)]
    assert max(offsets) < WRAP and min(offsets) > -WRAP
    assert any(b < a for a, b in zip(offsets, offsets[1:])), "it wrapped"
    assert touching(sim, 1)[-1].contact


def test_pair_plays_first_then_second_on_next_and_hides_labels():
    sim = Simulation(TextureScenario())
    sim.set_trial(Trial.parse(TextureScenario.TRIAL_PARAMS, "main", {"period_us": 4000, "second_period_us": 6000}))
    first = touching(sim, 40)[-1]
    assert first.output.cues[0].period_us == 4000 and first.output.hud == "Pair 1: first texture"
    sim.input("next", "press")
    second = touching(sim, 5)[-1]
    assert second.output.cues[0].period_us == 6000 and second.output.hud == "Pair 1: second texture"
    assert "Hz" not in second.output.hud


def test_identification_labels_only_in_training():
    sim = Simulation(TextureScenario())
    sim.input("2", "press")  # training: the experimenter picks 333.33 Hz
    train = touching(sim, 40)[-1]
    assert train.output.cues[0].period_us == 3000 and train.output.hud == "Texture 333.33 Hz"
    sim.set_trial(Trial.parse(TextureScenario.TRIAL_PARAMS, "main", {"period_us": 5000}, index=4))
    main = touching(sim, 5)[-1]
    assert main.output.cues[0].period_us == 5000 and main.output.hud == "Trial 5: which texture is this?"
    sim.input("1", "press")  # picking a texture is a training aid only
    assert touching(sim, 2)[-1].output.cues[0].period_us == 5000


def test_study_design_and_bad_trials():
    references, pairs, ident = TextureScenario.SUBTASKS
    assert [c["period_us"] for c in references.conditions] == [6000, 2000]
    assert [(c["period_us"], c["second_period_us"]) for c in pairs.conditions] == [(4000, p) for p in PERIODS_US]
    assert pairs.answer.low == 1 and pairs.answer.high == 7 and pairs.answer.labels[4] == "same"
    assert sorted(c["period_us"] for c in ident.conditions) == list(PERIODS_US)
    with pytest.raises(ParamError, match="period_us must be one of"):
        Trial.parse(TextureScenario.TRIAL_PARAMS, "main", {"period_us": 3500})
    with pytest.raises(ParamError, match="period_us is required"):
        Trial.parse(TextureScenario.TRIAL_PARAMS, "main", {})


def test_skin_goes_into_the_scene_and_bad_paths_are_refused():
    from scenarios.registry import create

    scene = create("texture", skin="/skins/stripes.svg", skin_tile=0.25).build_scene()
    assert scene.object(PLANE_ID).material.skin.to_dict() == {"image": "/skins/stripes.svg", "tile": [0.25, 0.25]}
    with pytest.raises(ParamError, match="must be a path on this server"):
        create("texture", skin="../../etc/passwd.png")
