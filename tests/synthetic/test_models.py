"""The observer models on their own: formulas, bounds, rounding, configuration."""

from __future__ import annotations

import dataclasses
import hashlib

import numpy as np
import pytest

from server.synthetic import (AngleEstimation, ForcedChoice, FrequencyIdentification, LikertRatings, ObserverModels,
                              PowerLaw, TextureComparison, derive_rng)
from server.synthetic.models import stochastic_round
from server.synthetic.rng import seed_from


def test_derive_rng_is_a_pure_function_of_its_parts():
    assert derive_rng(1, 2, 3, "q").random() == derive_rng(1, 2, 3, "q").random()
    assert derive_rng(1, 2, 3, "q").random() != derive_rng(1, 2, 4, "q").random()
    assert seed_from(1, 2) != seed_from("1", 2)
    # pinned: the seed is the SHA-256 of the parts' JSON text, never Python's salted hash()
    digest = hashlib.sha256(b'[1,0,5,"rating"]').digest()
    assert seed_from(1, 0, 5, "rating") == int.from_bytes(digest[:16], "big")


def test_angle_answers_are_on_the_grid_and_clipped():
    model = AngleEstimation()
    rng = np.random.default_rng(0)
    for angle in (-90.0, -50.0, 0.0, 10.0, 90.0):
        for _ in range(200):
            x = model.sample(rng, angle)
            assert -90.0 <= x <= 90.0 and x % 5.0 == 0.0 and isinstance(x, float)
    assert model.sd(0) == 10.0 and model.sd(90) == model.sd(-90) == 18.0 and model.sd(45) < 14.0
    coarse = dataclasses.replace(model, step_deg=10.0)
    assert {coarse.sample(rng, 30.0) % 10 for _ in range(100)} == {0.0}
    # bounds that are not multiples of the step are kept
    assert all(-42.0 <= model.sample(rng, -90.0, -42.0, 42.0) <= 42.0 for _ in range(100))


def test_an_uncompressed_angle_estimate_is_unbiased():
    model = AngleEstimation(compression=1.0, sd_center_deg=5.0, sd_edge_deg=5.0, step_deg=0.0)
    rng = np.random.default_rng(1)
    answers = [model.sample(rng, 40.0) for _ in range(4000)]
    assert abs(np.mean(answers) - 40.0) < 0.3 and abs(np.std(answers) - 5.0) < 0.3


def test_compression_pulls_toward_zero():
    rng = np.random.default_rng(2)
    means = [np.mean([AngleEstimation().sample(rng, a) for _ in range(3000)]) for a in (-50.0, 50.0)]
    assert means[0] == pytest.approx(-44.0, abs=0.8) and means[1] == pytest.approx(44.0, abs=0.8)


def test_comparison_direction_and_scale():
    model = TextureComparison(weber=0.0)
    rng = np.random.default_rng(3)
    assert model.sample(rng, 250.0, 166.67) == 6       # second rougher → above "same"
    assert model.sample(rng, 250.0, 500.0) == 1        # second smoother → below
    assert model.sample(rng, 250.0, 250.0) == 4
    assert TextureComparison(weber=0.0, rougher_is_high=False).sample(rng, 250.0, 166.67) == 2
    assert TextureComparison(weber=0.0, gain=100.0).sample(rng, 250.0, 166.67) == 7   # clipped to the scale
    assert TextureComparison(weber=0.0).sample(rng, 250.0, 166.67, 0, 10) == 7        # a 0..10 scale: 5 + 2


def test_identification_picks_the_nearest_in_log_frequency():
    choices = (500.0, 333.33, 250.0, 200.0, 166.67)
    rng = np.random.default_rng(4)
    assert [FrequencyIdentification(0.0).sample(rng, f, choices) for f in (500, 1e6 / 3000, 250, 200, 1e6 / 6000)] == \
        [0, 1, 2, 3, 4]
    # 290 Hz is nearer 250 in Hz but nearer 333.33 in log frequency (their geometric mean is 288.7)
    assert FrequencyIdentification(0.0).sample(rng, 290.0, choices) == 1
    assert FrequencyIdentification(0.0).sample(rng, 287.0, choices) == 2


def test_stochastic_rounding_keeps_the_mean():
    rng = np.random.default_rng(5)
    values = [stochastic_round(rng, 2.3) for _ in range(20000)]
    assert set(values) == {2, 3} and abs(np.mean(values) - 2.3) < 0.01
    assert stochastic_round(rng, 4.0) == 4


def test_power_law_answers_are_whole_levels_within_the_scale():
    rng = np.random.default_rng(6)
    loud = PowerLaw(1.164, 0.85, noise=1.0)
    answers = [loud.sample(rng, level) for level in range(1, 11) for _ in range(100)]
    assert all(isinstance(a, int) and 1 <= a <= 10 for a in answers) and {1, 10} <= set(answers)
    assert all(1 <= loud.sample(rng, 9, 1, 7) <= 7 for _ in range(100))
    assert PowerLaw(1.164, 0.85).mean(1) == 1.164


def test_likert_means_by_question_and_condition():
    model = LikertRatings()
    assert model.mean("helpfulness", "P3", 1, 7) == 5.36
    assert model.mean("helpfulness", "continuous-at-target", 1, 7) == 5.29   # the "*" entry
    assert model.mean("better_by", None, 1, 7) == 6.09
    assert model.mean("anything", "P1", 1, 7) == 4.0 and model.mean("anything", None, 0, 10) == 5.0
    custom = LikertRatings(means={"q": {"hot": 6.5}}, trial_sd=0.0)
    assert custom.sample(np.random.default_rng(0), "q", "hot") == 6     # round half to even
    assert custom.sample(np.random.default_rng(0), "q", "hot", leniency=2.0) == 7   # clipped


def test_forced_choice_same_option_and_utilities():
    rng = np.random.default_rng(7)
    never_same = ForcedChoice(same_threshold=0.0)
    assert "all felt the same" not in {never_same.sample(rng, "best_pattern", ("P1", "P2", "P3", "all felt the same"))
                                       for _ in range(300)}
    always_same = ForcedChoice(same_threshold=100.0)
    assert always_same.sample(rng, "x", ("A", "B", "both the same")) == "both the same"
    sure = ForcedChoice(utilities={"q": {"B": 50.0}})
    assert {sure.sample(rng, "q", ("A", "B", "C")) for _ in range(50)} == {"B"}
    assert {ForcedChoice().sample(rng, "q", (1.5, 2.5)) for _ in range(100)} == {1.5, 2.5}   # declared numbers
    assert ForcedChoice().sample(rng, "q", ("the same",)) == "the same"


def test_models_are_frozen_and_overridable():
    models = ObserverModels()
    with pytest.raises(dataclasses.FrozenInstanceError):
        models.angle.compression = 1.0
    with pytest.raises(TypeError):
        models.likert.means["better_by"] = 1.0
    changed = models.with_overrides({"estimation.b": "0.9", "angle.step_deg": 10, "comparison.rougher_is_high": "false",
                                     "estimation.high": "7", "text": "ok"})
    assert changed.estimation == PowerLaw(1.164, 0.9, high=7) and changed.angle.step_deg == 10.0
    assert changed.comparison.rougher_is_high is False and changed.text == "ok"
    assert models.estimation.b == 0.85   # the original is untouched
    for bad, message in (({"estimaton.b": 1}, "unknown model"), ({"estimation.c": 1}, "no field 'c'"),
                         ({"estimation.b": "x"}, "must be a number"), ({"estimation.high": 7.5}, "whole number"),
                         ({"likert.means": 1}, "dataclasses.replace"), ({"angle": 1}, "give a field"),
                         ({"estimation.b": "nan"}, "finite")):
        with pytest.raises(ValueError, match=message):
            models.with_overrides(bad)
