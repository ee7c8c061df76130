"""SyntheticParticipant: every answer of the thesis study is valid, dispatch, determinism."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from server.experiment.plan import plan_session
from server.experiment.question import Question
from server.synthetic import ObserverModels, SyntheticParticipant
from tests.synthetic.conftest import ROOT

SEED = 7


def session_answers(study, seed: int, participant: int) -> list:
    """[seq, question id, answer] of one participant's whole session, plus the produced levels."""
    p = SyntheticParticipant(seed, participant)
    out = []
    for trial in plan_session(study, participant):
        task = study.task(trial.task)
        out += [[trial.seq, qid, p.answer(trial, task.question(qid))] for qid in trial.questions]
        if trial.params.get("mode") == "production":
            out.append([trial.seq, "produced_level", p.produce_level(trial.params["level"], seq=trial.seq)])
    return out


def test_every_answer_of_the_thesis_study_is_valid(thesis):
    """13 participants, every planned item with questions: the answer passes Question.check
    unchanged (already in its normalised form and type), and every production is a level."""
    kinds = set()
    for i in range(13):
        p = SyntheticParticipant(SEED, i)
        for trial in plan_session(thesis, i):
            task = thesis.task(trial.task)
            for qid in trial.questions:
                q = task.question(qid)
                value = p.answer(trial, q)
                checked = q.check(value)
                assert checked == value and type(checked) is type(value), (trial.task, qid, value)
                kinds.add(q.kind)
            if trial.params.get("mode") == "production":
                level = p.produce_level(trial.params["level"], seq=trial.seq)
                assert isinstance(level, int) and 1 <= level <= 10
    assert kinds == {"number", "likert", "choice"}


def test_the_same_seed_gives_the_same_answers_in_another_process(thesis):
    """A fresh interpreter with a different string-hash salt gives the same answers."""
    here = [session_answers(thesis, SEED, i) for i in range(13)]
    script = (
        "import json\n"
        "from server.experiment.study import load_study\n"
        "from tests.synthetic.test_participant import session_answers\n"
        "study = load_study('studies/thesis-2021.toml')\n"
        f"print(json.dumps([session_answers(study, {SEED}, i) for i in range(13)]))\n")
    for salt in ("0", "4242"):
        env = dict(os.environ, PYTHONHASHSEED=salt)
        out = subprocess.run([sys.executable, "-c", script], cwd=ROOT, env=env, capture_output=True, text=True,
                             check=True).stdout
        assert json.loads(out) == json.loads(json.dumps(here))


def test_answers_do_not_depend_on_call_order_or_instance(thesis):
    plan = plan_session(thesis, 2)
    asked = [(t, thesis.task(t.task).question(qid)) for t in plan for qid in t.questions]
    forward = [SyntheticParticipant(SEED, 2).answer(t, q) for t, q in asked]
    p = SyntheticParticipant(SEED, 2)
    backward = [p.answer(t, q) for t, q in reversed(asked)][::-1]
    assert forward == backward
    # the dict form of a planned trial gives the same answers
    assert [SyntheticParticipant(SEED, 2).answer(t.to_dict(), q) for t, q in asked] == forward


def test_seeds_and_participants_differ(thesis):
    a = session_answers(thesis, SEED, 0)
    assert a != session_answers(thesis, SEED + 1, 0)
    assert a != session_answers(thesis, SEED, 1)
    assert a == session_answers(thesis, SEED, 0)


def test_produce_level_with_and_without_seq():
    p, q = SyntheticParticipant(1, 0), SyntheticParticipant(1, 0)
    assert [p.produce_level(5, seq=s) for s in range(20)] == [q.produce_level(5, seq=s) for s in range(20)]
    # without a seq the draws follow this participant's count of productions
    first, second = SyntheticParticipant(1, 0), SyntheticParticipant(1, 0)
    assert [first.produce_level(level) for level in range(1, 11)] == \
        [second.produce_level(level) for level in range(1, 11)]
    perfect = ObserverModels().with_overrides({"production.noise": 0, "production.a": 1, "production.b": 1})
    assert [SyntheticParticipant(1, 0, perfect).produce_level(level) for level in range(1, 11)] == list(range(1, 11))


LIKERT = Question("q", "likert", "How much?", 0, 10)
CHOICE = Question("pick", "choice", "Which?", choices=("A", "B", "C"))
NUMBER = Question("n", "number", "How many?", 1, 10, integer=True)
TEXT = Question("t", "text", "Anything else?")


@pytest.mark.parametrize("scenario", ["shape-v1", "friction-temperature-v1", "contact-angle-v1", "texture-v1"])
def test_generic_questions_of_any_scenario(scenario):
    """Questions the scenario models do not cover fall back to the generic models by kind."""
    p = SyntheticParticipant(3, 1)
    trial = {"seq": 9, "scenario": scenario, "params": {}}
    likert = [SyntheticParticipant(3, i).answer(trial, LIKERT) for i in range(300)]
    assert all(0 <= v <= 10 and isinstance(v, int) for v in likert)
    assert 4.0 < sum(likert) / len(likert) < 6.0   # unknown item: the scale's middle
    picks = [SyntheticParticipant(3, i).answer(trial, CHOICE) for i in range(600)]
    assert {picks.count(c) > 150 for c in "ABC"} == {True}   # unknown choice: uniform
    assert p.answer(trial, NUMBER) == 5 and p.answer(trial, Question("x", "number", "?")) == 0.0
    assert p.answer(trial, TEXT) == "no comment"
    assert SyntheticParticipant(3, 1, ObserverModels(text="fine")).answer(trial, TEXT) == "fine"


def test_dispatch_uses_the_scenario_models():
    perfect = ObserverModels().with_overrides({
        "angle.compression": 1, "angle.sd_center_deg": 0, "angle.sd_edge_deg": 0,
        "identification.weber": 0, "estimation.noise": 0, "estimation.a": 1, "estimation.b": 1})
    p = SyntheticParticipant(0, 0, perfect)
    angle = Question("answer_deg", "number", "?", -90, 90)
    assert p.answer({"seq": 1, "scenario": "contact-angle-v1", "params": {"angle_deg": -70.0}}, angle) == -70.0
    assert p.answer({"seq": 1, "scenario": "contact-angle", "params": {"angle_deg": 33.0}}, angle) == 35.0  # 5° steps
    hz = Question("answer_hz", "choice", "?", choices=(500.0, 333.33, 250.0, 200.0, 166.67))
    assert p.answer({"seq": 2, "scenario": "texture-v1", "params": {"period_us": 3000.0}}, hz) == 333.33
    level = Question("answer_level", "number", "?", 1, 10, integer=True)
    for lv in range(1, 11):
        trial = {"seq": lv, "scenario": "stiffness-v1", "params": {"mode": "estimation", "level": lv}}
        assert p.answer(trial, level) == lv
    # a pair with the same texture twice, no noise: "same"; the rougher second one rates higher
    cmp = ObserverModels().with_overrides({"comparison.weber": 0})
    rating = Question("rating", "likert", "?", 1, 7)
    pair = {"seq": 3, "scenario": "texture-v1", "params": {"period_us": 4000.0, "second_period_us": 4000.0}}
    assert SyntheticParticipant(0, 0, cmp).answer(pair, rating) == 4
    ratings = [SyntheticParticipant(0, 0, cmp).answer(dict(pair, params={"period_us": 4000.0, "second_period_us": s}),
                                                      rating) for s in (2000.0, 3000.0, 5000.0, 6000.0)]
    assert ratings == [1, 3, 4, 6]  # log ratios −0.69, −0.29, +0.22 (inside the same band), +0.41


def test_bad_trials_are_refused():
    p = SyntheticParticipant(0, 0)
    with pytest.raises(TypeError):
        p.answer({"scenario": "texture-v1"}, TEXT)
    with pytest.raises(TypeError):
        p.answer({"seq": "1", "scenario": "texture-v1"}, TEXT)
