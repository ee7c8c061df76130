"""The psychometric participant (server/synthetic/psychometric.py): its answers follow its own
psychometric function for every design, its thresholds have the declared shape (a U over the
carrier with its minimum at 250 Hz; Weber's law for discrimination), it is seeded."""

from __future__ import annotations


import numpy as np
import pytest
from scipy.stats import binomtest

from server.synthetic import ObserverModels, SyntheticParticipant
from server.synthetic.psychometric import PsyAnswerError, PsychometricModel, to_db

N = 3000  # answers per checked probability: a 99.9 % interval is about ±3 points


def within_ci(successes: int, n: int, p: float) -> bool:
    ci = binomtest(successes, n).proportion_ci(0.999, method="exact")
    return ci.low <= p <= ci.high


def psy(design="2ifc", level=5.0, reference=None, parameter="intensity_pct", **extra):
    choices = {"2ifc": ["1", "2"], "nafc": ["1", "2", "3", "4"], "yes-no": ["yes", "no"],
               "same-different": ["same", "different"]}.get(design, ["a", "b", "c"])
    return {"design": design, "parameter": parameter, "level": level, "reference": reference, "target": None,
            "signal": None, "stimulus_index": None, "choices": choices, "condition": None, **extra}


@pytest.fixture
def observer():
    return PsychometricModel().participant(seed=7, participant=3)


@pytest.mark.parametrize("design,target", [("2ifc", 2), ("nafc", 3)])
@pytest.mark.parametrize("offset_db", [-4.0, 0.0, 3.0])
def test_forced_choice_answers_follow_the_function(observer, design, target, offset_db):
    threshold_db = observer.detection_threshold_db(250.0)
    record = psy(design, level=100 * 10 ** ((threshold_db + offset_db) / 20), target=target)
    p = observer.probability(record, {"carrier_hz": 250.0})
    rng = np.random.default_rng(1)
    answers = [observer.answer(record, rng, {"carrier_hz": 250.0}) for _ in range(N)]
    correct = sum(a == record["choices"][target - 1] for a in answers)
    assert within_ci(correct, N, p)
    # a wrong answer is any other interval, evenly
    wrong = [a for a in answers if a != record["choices"][target - 1]]
    assert set(wrong) == set(record["choices"]) - {record["choices"][target - 1]}
    assert 1 / len(record["choices"]) < p < 1


def test_yes_no_hits_and_false_alarms(observer):
    level = 100 * 10 ** (observer.detection_threshold_db(None) / 20)
    rng = np.random.default_rng(2)
    signal = psy("yes-no", level=level, signal=True)
    catch = psy("yes-no", level=0.0, signal=False)
    hits = sum(observer.answer(signal, rng) == "yes" for _ in range(N))
    false_alarms = sum(observer.answer(catch, rng) == "yes" for _ in range(N))
    assert within_ci(hits, N, observer.probability(signal))
    assert within_ci(false_alarms, N, observer.model.false_alarm)
    assert observer.probability(signal) > observer.model.false_alarm


def test_same_different_follows_the_difference(observer):
    rng = np.random.default_rng(3)
    different = psy("same-different", level=240.0, reference=200.0, parameter="carrier_hz", signal=True)
    same = psy("same-different", level=200.0, reference=200.0, parameter="carrier_hz", signal=False)
    said = sum(observer.answer(different, rng) == "different" for _ in range(N))
    assert within_ci(said, N, observer.probability(different))
    said_same = sum(observer.answer(same, rng) == "different" for _ in range(N))
    assert within_ci(said_same, N, observer.model.false_alarm)


def test_threshold_is_a_u_over_frequency_lowest_at_250_hz(observer):
    frequencies = [40, 80, 160, 250, 400, 800]
    thresholds = [observer.detection_threshold_db(f) for f in frequencies]
    assert np.argmin(thresholds) == frequencies.index(250)
    assert thresholds[0] > thresholds[1] > thresholds[2] > thresholds[3] < thresholds[4] < thresholds[5]
    # the participant's own offset moves the whole curve
    assert thresholds[3] == pytest.approx(-30.0 + observer.offset_db)


def test_discrimination_follows_webers_law(observer):
    """p at Δ = k·I is the same at every reference I, and threshold() is I + k·I."""
    k = observer.difference_threshold("carrier_hz", 100.0) / 100.0
    ps = [observer.probability(psy("2ifc", level=ref * (1 + k), reference=ref, parameter="carrier_hz", target=1))
          for ref in (50.0, 200.0, 400.0)]
    assert ps == pytest.approx([ps[0]] * 3)
    assert observer.threshold("carrier_hz", 200.0) == pytest.approx(200.0 * (1 + k))
    assert 0.5 < ps[0] < 1


def test_identification_confuses_neighbours_more_than_distant_stimuli(observer):
    values = [100.0, 150.0, 225.0, 337.5]
    rng = np.random.default_rng(4)
    confusion = np.zeros((4, 4), int)
    for index in range(4):
        record = psy("identification", level=values[index], parameter="carrier_hz", stimulus_index=index,
                     choices=["100", "150", "225", "337.5"])
        for _ in range(500):
            confusion[index, observer.identify(record, rng)] += 1
    assert all(confusion[i, i] == confusion[i].max() for i in range(4))
    assert confusion[0, 1] > confusion[0, 3] and confusion[3, 2] > confusion[3, 0]
    # labels that are not numbers: confusion on the index axis, still mostly right
    record = psy("identification", level=2.0, parameter="period_us", stimulus_index=2,
                 choices=["smooth", "fine", "medium", "coarse"])
    answers = [observer.answer(record, rng) for _ in range(500)]
    assert max(set(answers), key=answers.count) == "medium"


def test_a_participant_is_seeded_and_participants_differ():
    model = PsychometricModel()
    a, b = model.participant(1, 0), model.participant(1, 0)
    assert model == PsychometricModel()
    assert (a.offset_db, a.slope_factor, a.weber_factor, a.lapse) == (b.offset_db, b.slope_factor, b.weber_factor,
                                                                       b.lapse)
    others = [model.participant(1, i).offset_db for i in range(1, 200)]
    assert np.std(others) == pytest.approx(model.threshold_sd_db, rel=0.2)
    lapses = [model.participant(1, i).lapse for i in range(200)]
    assert 0 <= min(lapses) and max(lapses) <= model.lapse_max


def test_the_synthetic_participant_answers_a_psy_record_through_its_seed():
    trial = {"seq": 12, "scenario": "stimulus-v1", "scenario_params": {"carrier_hz": 250.0}, "params": {}}
    record = psy("2ifc", level=3.0, target=2)
    first = SyntheticParticipant(5, 1).answer_psychophysics(trial, record)
    assert first in ("1", "2")
    assert all(SyntheticParticipant(5, 1).answer_psychophysics(trial, record) == first for _ in range(5))
    # the population setting reaches the psychometric model (`--set psychometric.minimum_db=-10`)
    models = ObserverModels().with_overrides({"psychometric.minimum_db": "-10"})
    assert SyntheticParticipant(5, 1, models).psychometric.detection_threshold_db(250.0) == pytest.approx(
        -10.0 + SyntheticParticipant(5, 1).psychometric.offset_db)


@pytest.mark.parametrize("record,message", [
    (psy("2ifc", target=3), "psy.target"),
    (psy("2ifc", target=1, choices=["1"]), "psy.choices"),
    (psy("odd-one-out", target=1), "unknown design"),
    (psy("2ifc", target=1, parameter="duration_ms"), "needs a reference"),
    (psy("2ifc", target=1, reference=3.0, parameter="loudness"), "no discrimination threshold for 'loudness'"),
    (psy("identification", stimulus_index=7), "psy.stimulus_index"),
])
def test_a_record_it_cannot_answer_is_refused_by_name(observer, record, message):
    with pytest.raises(PsyAnswerError, match=message):
        observer.answer(record, np.random.default_rng(0))


def test_db_of_levels():
    assert to_db(100.0) == 0.0 and to_db(10.0) == pytest.approx(-20.0) and to_db(0.0) == -np.inf
