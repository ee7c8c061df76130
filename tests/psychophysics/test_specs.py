"""Procedure specs from plain dicts: errors name the field, suggest the name meant, and refuse
specs that cannot converge or cannot stop."""

import pytest

from server.psychophysics.procedures import parse_procedure
from server.psychophysics.spec import SpecError

UP_DOWN = {"kind": "up-down", "start": 20.0, "steps": [4, 2], "max_trials": 50}


def refused(table, *fragments):
    with pytest.raises(SpecError) as info:
        parse_procedure(table, 'procedure "low"')
    text = str(info.value)
    assert text.startswith('procedure "low"'), text
    for fragment in fragments:
        assert fragment in text, text
    return text


def test_an_unknown_kind_suggests_the_one_meant():
    refused({**UP_DOWN, "kind": "up-dwon"}, "kind", "did you mean 'up-down'")
    refused({"start": 1}, "kind: missing")


def test_an_unknown_field_suggests_the_one_meant():
    refused({**UP_DOWN, "max_reversal": 8}, "unknown field 'max_reversal'", "did you mean 'max_reversals'")
    refused({**UP_DOWN, "stpes": [1]}, "did you mean 'steps'")


def test_missing_and_wrongly_typed_fields_are_named():
    refused({k: v for k, v in UP_DOWN.items() if k != "start"}, "start: missing")
    refused({**UP_DOWN, "steps": "4"}, "steps: expected a list")
    refused({**UP_DOWN, "down": 1.5}, "down: expected a whole number")
    refused({**UP_DOWN, "start": float("nan")}, "start: expected a finite number")


def test_steps_of_zero_and_no_stop_are_refused():
    refused({**UP_DOWN, "steps": [2, 0]}, "steps", "> 0")
    refused({k: v for k, v in UP_DOWN.items() if k != "max_trials"}, "needs a stop")
    refused({**UP_DOWN, "scale": "log", "steps": [1.0]}, "factors > 1")


def test_reversed_bounds_and_a_start_outside_them_are_refused():
    refused({**UP_DOWN, "min": 10.0, "max": 5.0}, "max", "reversed")
    refused({**UP_DOWN, "min": 0.0, "max": 10.0}, "start", "outside the bounds")
    refused({**UP_DOWN, "scale": "db", "start": -3.0}, "start", "> 0")


def test_a_weighted_target_outside_guess_to_one_cannot_converge():
    weighted = {"kind": "weighted-up-down", "start": 10.0, "steps": [1.0], "max_trials": 40, "guess": 0.5}
    refused({**weighted, "target": 0.4}, "target", "(guess, 1)")
    refused({**weighted, "target": 1.0}, "target")
    assert parse_procedure({**weighted, "target": 0.75}).steps_up == (3.0,)


def test_a_transformed_rule_converging_below_the_guess_rate_is_refused():
    refused({**UP_DOWN, "up": 2, "down": 1, "guess": 0.5}, "2-up/1-down", "0.293", "cannot converge")
    assert parse_procedure({**UP_DOWN, "up": 2, "down": 1}).target == pytest.approx(1 - 0.5 ** 0.5)


def test_ladders_step_by_whole_rungs_from_a_rung():
    ladder = {"kind": "up-down", "scale": "ladder", "levels": [1, 2, 4, 8], "steps": [1], "max_trials": 9}
    assert parse_procedure(ladder).start == 4.0  # the middle rung by default
    refused({**ladder, "start": 3}, "start", "one of the ladder's levels")
    refused({**ladder, "steps": [1.5]}, "whole rungs")
    refused({**ladder, "levels": [1, 4, 2]}, "increase strictly")
    refused({**ladder, "min": 1}, "min", "ends")


def test_quest_plus_fields():
    quest = {"kind": "quest-plus", "levels": [1, 2, 3], "threshold": [1, 2, 3], "slope": [1, 2], "max_trials": 5}
    spec = parse_procedure(quest)
    assert spec.family == "weibull" and dict(spec.params)["guess"] == (0.5,)
    refused({**quest, "family": "logistc"}, "family", "did you mean 'logistic'")
    refused({**quest, "slope": [0, 1]}, "slope", "> 0")
    refused({**quest, "levels": [0, 1]}, "levels", "> 0")
    refused({**quest, "threshold": {"from": 3, "to": 1, "count": 4}}, "threshold", "below")
    refused({**quest, "prior": {"threshold": [2, 0]}}, "prior", "sd > 0")
    refused({**quest, "prior": {"treshold": [2, 1]}}, "did you mean 'threshold'")
    refused({**quest, "focus": ["guess"]}, "focus", "fixed")
    refused({**quest, "focus": ["slop"]}, "focus", "did you mean 'slope'")


def test_interleaved_errors_name_the_condition():
    text = refused({"kind": "interleaved", "conditions": {"250 Hz": {**UP_DOWN, "steps": [0]}}}, "250 Hz", "steps")
    assert 'condition "250 Hz"' in text
    refused({"kind": "interleaved", "conditions": {}}, "conditions", "at least one")


def test_constant_stimuli_fields():
    refused({"kind": "constant", "levels": [1, 1], "repeats": 2}, "levels", "twice")
    refused({"kind": "constant", "levels": [1, 2], "repeats": 0}, "repeats", "≥ 1")
    refused({"kind": "constant", "levels": [1, 2], "repeats": 2, "order": "rnd"}, "did you mean 'random'")
