"""The psychometric participant through the production procedures (server/psychophysics) recovers
its own threshold: a 1-up/2-down staircase converges on its 70.7 % point, QUEST+ on its threshold
parameter. Seeded, bounded samples (the engine is not needed: the procedures are the engine's)."""

from __future__ import annotations

import numpy as np
import pytest

from server.psychophysics.procedures import parse_procedure, start
from server.synthetic.psychometric import PsychometricModel, to_db
from server.synthetic.rng import derive_rng

CARRIER = {"carrier_hz": 250.0}


def run_2ifc(spec, observer, rng):
    """The finished procedure after a 2IFC detection track answered by `observer`."""
    procedure = start(spec, 0)
    while not procedure.finished:
        target = int(rng.integers(1, 3))
        psy = {"design": "2ifc", "parameter": "intensity_pct", "level": procedure.level, "reference": None,
               "target": target, "choices": ["1", "2"]}
        procedure.update(observer.answer(psy, rng, CARRIER) == str(target))
    return procedure


def observers(n: int, seed: int = 11):
    model = PsychometricModel()
    return [model.participant(seed, i) for i in range(n)]


def test_a_1up_2down_staircase_converges_on_each_participants_70_7_percent_point():
    spec = parse_procedure({"kind": "up-down", "scale": "db", "start": 50.0, "steps": [4, 2], "min": 0.01,
                            "max": 100.0, "max_reversals": 14, "average": 8})
    errors, truths = [], []
    for i, observer in enumerate(observers(150)):
        procedure = run_2ifc(spec, observer, derive_rng("recovery-staircase", i))
        psychometric, _ = observer.observer({"parameter": "intensity_pct", "level": 1.0, "reference": None},
                                            0.5, CARRIER)
        true_db = psychometric.level_at(0.5 ** 0.5)  # Levitt 1971: 1-up/2-down → p = 0.707
        errors.append(to_db(procedure.estimate()) - true_db)
        truths.append(true_db)
    errors = np.asarray(errors)
    assert abs(errors.mean()) < 1.0            # unbiased to within 1 dB on average
    assert errors.std() < 3.0                  # each run lands within a few dB
    estimates = np.asarray(truths) + errors
    assert np.corrcoef(truths, estimates)[0, 1] > 0.75  # it tracks each participant's own threshold


def test_quest_plus_recovers_the_threshold_parameter():
    """Weibull on the amplitude (%) is the model's Gumbel on dB: QUEST+'s threshold is the model's α."""
    model = PsychometricModel()
    spec = parse_procedure({"kind": "quest-plus", "family": "weibull",
                            "levels": {"from": 0.3, "to": 100, "count": 40, "spacing": "log"},
                            "threshold": {"from": 0.5, "to": 50, "count": 40, "spacing": "log"},
                            "slope": [model.slope * 20 / np.log(10)], "guess": 0.5, "lapse": [0.0, 0.03],
                            "max_trials": 60, "focus": ["threshold"]})
    errors = []
    for i, observer in enumerate(observers(40, seed=12)):
        procedure = run_2ifc(spec, observer, derive_rng("recovery-quest", i))
        true = observer.threshold("intensity_pct", None, CARRIER)
        errors.append(to_db(procedure.estimate()) - to_db(true))
    errors = np.asarray(errors)
    assert abs(errors.mean()) < 1.0
    assert np.sqrt(np.mean(errors ** 2)) < 3.0
    assert np.median(np.abs(errors)) == pytest.approx(0.0, abs=2.0)
