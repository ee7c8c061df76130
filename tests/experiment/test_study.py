"""Study files: loading, the scenario-backed checks, questions, and one clear error per mistake."""

from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path

import pytest

from server.core.scenario import Param
from server.experiment.question import AnswerError, Question, question_from_answer
from server.experiment.study import StudyError, load_study, parse_study

ROOT = Path(__file__).resolve().parents[2]
THESIS = ROOT / "studies" / "thesis-2021.toml"

HEAD = """
id = "mini"
title = "A small study"
seed = 1
participants = 4
"""
ANGLES = """
[[tasks]]
id = "angles"
scenario = "contact-angle"
conditions = [{ angle_deg = 10 }, { angle_deg = -10 }]
"""


def mini(*parts: str):
    return parse_study(HEAD + "".join(parts), "mini.toml")


def error_of(*parts: str) -> str:
    with pytest.raises(StudyError) as caught:
        mini(*parts)
    return str(caught.value)


# ---- loading -----------------------------------------------------------------------------------

def test_minimal_study():
    study = mini(ANGLES)
    assert (study.id, study.title, study.version, study.seed, study.participants) == ("mini", "A small study", 1, 1, 4)
    task = study.task("angles")
    assert task.scenario == "contact-angle-v1"  # the bare name resolves to the versioned id
    assert task.title == "Contact angle (hemisphere, Algorithm 1)"  # no title: the scenario's
    assert dict(task.params) == {"magnitude_pct": 100.0, "stiffness_n_per_m": 1000.0, "probe": "hip"}
    assert [dict(c) for c in task.conditions] == [{"angle_deg": 10.0, "time_limit_s": 30.0},
                                                  {"angle_deg": -10.0, "time_limit_s": 30.0}]
    assert (task.device, task.order, task.repetitions, task.practice, task.training_s) == (None, "random", 1, 0, 0.0)
    assert task.time_limit_s is None and task.questions == () and task.block is None and study.blocks == ()
    assert study.source_hash == hashlib.sha256((HEAD + ANGLES).encode()).hexdigest()


def test_study_is_frozen_and_serialisable():
    study = mini(ANGLES)
    with pytest.raises(dataclasses.FrozenInstanceError):
        study.tasks[0].order = "fixed"
    with pytest.raises(TypeError):
        study.tasks[0].params["probe"] = "proxy"
    again = json.loads(json.dumps(study.to_dict()))
    assert again["tasks"][0]["conditions"][0] == {"angle_deg": 10.0, "time_limit_s": 30.0}
    with pytest.raises(KeyError):
        study.task("nope")


def test_thesis_study_loads():
    study = load_study(THESIS)
    assert study.id == "thesis-2021" and study.participants == 13
    assert study.source_hash == hashlib.sha256(THESIS.read_text(encoding="utf-8").encode()).hexdigest()
    scenarios = {t.scenario for t in study.tasks}
    assert scenarios == {"contact-angle-v1", "texture-v1", "stiffness-v1", "positioning-v1"}
    assert {t.device for t in study.tasks} == {"ferrovibe", "fingertac"}
    json.dumps(study.to_dict())


def test_thesis_study_tasks_follow_the_thesis():
    study = load_study(THESIS)
    angle = study.task("contact_angle")
    assert (len(angle.conditions), angle.practice, angle.training_s, angle.time_limit_s) == (10, 3, 120.0, 30.0)
    assert angle.questions[0].kind == "number" and (angle.questions[0].low, angle.questions[0].high) == (-90, 90)
    pairs = study.task("texture_pairs")
    assert pairs.order == "latin" and len(pairs.conditions) == 5
    assert pairs.questions[0].kind == "likert" and dict(pairs.questions[0].labels) == {
        1: "much smoother", 4: "same", 7: "much rougher"}
    assert [c["period_us"] for c in pairs.training_conditions] == [6000.0, 2000.0]
    ident = study.task("texture_identification")
    assert ident.questions[0].choices == (500.0, 333.33, 250.0, 200.0, 166.67)
    estimation = study.task("stiffness_estimation")
    assert estimation.questions[0].kind == "number" and estimation.questions[0].integer
    assert study.task("stiffness_production").questions == ()  # the scenario records the result
    patterns = study.task("positioning_patterns")
    assert len(patterns.conditions) == 9 and patterns.questions[0].id == "helpfulness"
    assert "all felt the same" in patterns.end_questions[0].choices
    modes = study.task("modes_questionnaire").end_questions
    assert [q.id for q in modes] == ["better_mode", "better_by"]
    assert modes[1].labels[1] == "both felt the same"
    assert [b.tasks for b in study.blocks] == [("mode_continuous", "mode_none")]
    assert study.task("mode_none").block == "vibration_modes"
    assert study.task("positioning_ferrovibe").device == "ferrovibe"


# ---- subtasks ----------------------------------------------------------------------------------

def test_subtask_supplies_the_design_and_file_fields_override_it():
    study = mini("""
[[tasks]]
id = "angles"
scenario = "contact-angle"
subtask = "angles"
practice = 1
time_limit_s = 0
""")
    task = study.task("angles")
    assert len(task.conditions) == 10 and task.training_s == 120.0 and task.subtask == "angles"
    assert task.practice == 1 and task.time_limit_s is None  # overridden; 0 = no limit
    assert task.questions == (Question("answer_deg", "number", "Which angle do you feel?", -90.0, 90.0),)
    assert task.title == "Contact angle discrimination (thesis §5.2)"


def test_explicit_questions_replace_the_subtask_answer():
    study = mini("""
[[tasks]]
id = "levels"
scenario = "stiffness"
subtask = "estimation"

[[tasks.questions]]
id = "level"
kind = "likert"
text = "Level?"
low = 1
high = 10
""")
    assert [q.id for q in study.task("levels").questions] == ["level"]


def test_answer_params_become_questions():
    likert = question_from_answer(Param("rating", "int", "doc", 4, 1, 7, labels={1: "a", 7: "b"}), "Q?")
    assert (likert.kind, likert.low, likert.high, dict(likert.labels), likert.text) == ("likert", 1, 7,
                                                                                        {1: "a", 7: "b"}, "Q?")
    whole = question_from_answer(Param("level", "int", "the level", None, 1, 10), "")
    assert (whole.kind, whole.integer, whole.low, whole.high, whole.text) == ("number", True, 1, 10, "the level")
    unlabelled = question_from_answer(Param("r", "int", "d", None, 1, 7), "")
    assert unlabelled.kind == "number"
    choice = question_from_answer(Param("hz", "choice", "d", None, choices=(500.0, 250.0)), "")
    assert (choice.kind, choice.choices) == ("choice", (500.0, 250.0))
    assert question_from_answer(Param("x", "number", "d", 0.0, -1, 1), "").kind == "number"
    assert question_from_answer(Param("ok", "bool", "d", True), "").choices == ("yes", "no")
    assert question_from_answer(Param("note", "text", "d", ""), "").kind == "text"


# ---- questions ---------------------------------------------------------------------------------

def test_likert_answers():
    q = Question("rating", "likert", "How?", 1, 7)
    assert q.check(4) == 4 and q.check(7.0) == 7 and q.check("2") == 2
    for bad in (9, 0, 3.5, "much", True, float("nan")):
        with pytest.raises(AnswerError):
            q.check(bad)
    with pytest.raises(AnswerError) as caught:
        q.check(9)
    assert str(caught.value) == "rating must be a whole number from 1 to 7, got 9"


def test_number_answers():
    q = Question("answer_deg", "number", "Angle?", -90, 90)
    assert q.check(-45) == -45.0 and isinstance(q.check(10), float) and q.check(" 12.5 ") == 12.5
    with pytest.raises(AnswerError, match=r"answer_deg must be a number from -90 to 90, got 120"):
        q.check(120)
    whole = Question("level", "number", "Level?", 1, 10, integer=True)
    assert whole.check(3.0) == 3 and isinstance(whole.check(3.0), int)
    with pytest.raises(AnswerError, match="whole number"):
        whole.check(2.5)
    free = Question("x", "number", "?")
    assert free.check(-1e9) == -1e9
    with pytest.raises(AnswerError):
        free.check(float("inf"))
    with pytest.raises(AnswerError, match="of at least 0"):
        Question("t", "number", "?", low=0).check(-1)


def test_choice_answers():
    hz = Question("answer_hz", "choice", "Which?", choices=(500.0, 333.33, 250.0))
    assert hz.check(500) == 500.0 and hz.check("333.33") == 333.33
    words = Question("best", "choice", "Which?", choices=("P1", "P2", "all felt the same"))
    assert words.check("all felt the same") == "all felt the same" and words.check(" P2 ") == "P2"
    for bad in ("P4", 1, True):
        with pytest.raises(AnswerError, match="best must be one of 'P1', 'P2', 'all felt the same'"):
            words.check(bad)
    with pytest.raises(AnswerError):
        hz.check(True)


def test_text_and_required_answers():
    note = Question("note", "text", "Anything?", required=False)
    assert note.check("felt fine") == "felt fine" and note.check(None) is None and note.check("  ") is None
    with pytest.raises(AnswerError, match="at most 2000"):
        note.check("x" * 2001)
    with pytest.raises(AnswerError):
        note.check(5)
    with pytest.raises(AnswerError, match="rating: an answer is required"):
        Question("rating", "likert", "How?", 1, 7).check(None)


def test_questions_from_the_file():
    study = mini(ANGLES, """
[[tasks.questions]]
id = "confidence"
kind = "likert"
text = "How sure are you?"
labels = { 1 = "guessing", 7 = "certain" }

[[tasks.end_questions]]
id = "comments"
kind = "text"
text = "Comments"
required = false

[[tasks.end_questions]]
id = "hand"
kind = "choice"
text = "Hand?"
choices = ["left", "right"]
""")
    task = study.task("angles")
    confidence = task.question("confidence")
    assert (confidence.low, confidence.high, dict(confidence.labels)) == (1, 7, {1: "guessing", 7: "certain"})
    assert not task.question("comments").required and task.question("hand").choices == ("left", "right")
    with pytest.raises(KeyError):
        task.question("nope")


# ---- validation errors ------------------------------------------------------------------------

def test_unknown_task_field_with_did_you_mean():
    assert error_of(ANGLES, 'oder = "fixed"\n') == \
        "mini.toml: task \"angles\": unknown field 'oder' (did you mean 'order'?)"


def test_unknown_fields_everywhere():
    assert "mini.toml: unknown field 'sed' (did you mean 'seed'?)" in error_of('sed = 2\n', ANGLES)
    assert "unknown field 'txt' (did you mean 'text'?)" in error_of(
        ANGLES, '[[tasks.questions]]\nid = "q"\nkind = "text"\ntxt = "?"\n')
    assert "block \"b\": unknown field 'order_by'" in error_of(
        ANGLES, ANGLES.replace('"angles"', '"more"'), '[[blocks]]\nid = "b"\ntasks = ["angles", "more"]\norder_by = 1\n')


def test_missing_required_fields():
    assert error_of('[[tasks]]\nid = "t"\n') == "mini.toml: task \"t\": missing required field 'scenario'"
    with pytest.raises(StudyError, match="missing required field 'seed'"):
        parse_study(HEAD.replace("seed = 1\n", "") + ANGLES, "mini.toml")
    assert "missing required field 'text'" in error_of(ANGLES, '[[tasks.questions]]\nid = "q"\nkind = "text"\n')
    assert "missing required field 'tasks'" in error_of(ANGLES, '[[blocks]]\nid = "b"\n')
    with pytest.raises(StudyError, match="missing required field 'tasks'"):
        parse_study(HEAD, "mini.toml")


def test_unknown_scenario_uses_the_registry_message():
    message = error_of(ANGLES.replace('"contact-angle"', '"contact-angel"'))
    assert message.startswith('mini.toml: task "angles": unknown scenario \'contact-angel\'; did you mean')
    assert "contact-angle" in message


def test_bad_scenario_and_trial_params_carry_the_param_error():
    message = error_of(ANGLES, "params = { magnitude_pct = 150 }\n")
    assert message.startswith('mini.toml: task "angles": params: contact-angle-v1.magnitude_pct must be in')
    message = error_of(ANGLES.replace("angle_deg = -10", "angle_deg = -120"))
    assert message.startswith('mini.toml: task "angles": conditions[1].angle_deg must be in [-90.0, 90.0]')
    assert "unknown parameter(s) angel_deg" in error_of(ANGLES.replace("{ angle_deg = 10 }", "{ angel_deg = 10 }"))
    assert "params: contact-angle-v1: unknown parameter(s) colour" in error_of(ANGLES, 'params = { colour = 1 }\n')


def test_unknown_order_and_device():
    assert "unknown order 'randum' (did you mean 'random'?)" in error_of(ANGLES, 'order = "randum"\n')
    assert "unknown device model 'ferovibe' (did you mean 'ferrovibe'?)" in error_of(ANGLES, 'device = "ferovibe"\n')
    # a device the scenario's cues do not suit is not refused here: devices are checked at run time
    assert mini(ANGLES, 'device = "fingertac"\n').task("angles").device == "fingertac"


def test_latin_needs_two_conditions():
    one = ANGLES.replace(", { angle_deg = -10 }", "")
    assert 'order "latin" needs at least 2 conditions, got 1' in error_of(one, 'order = "latin"\n')


def test_block_errors():
    more = ANGLES.replace('"angles"', '"more"')
    assert "block \"b\": unknown task 'angels' (did you mean 'angles'?)" in error_of(
        ANGLES, more, '[[blocks]]\nid = "b"\ntasks = ["angels", "more"]\n')
    assert "block \"c\": task 'angles' is already in block \"b\"" in error_of(
        ANGLES, more, ANGLES.replace('"angles"', '"third"'),
        '[[blocks]]\nid = "b"\ntasks = ["angles", "more"]\n[[blocks]]\nid = "c"\ntasks = ["angles", "third"]\n')
    assert "at least 2 tasks, got 1" in error_of(ANGLES, '[[blocks]]\nid = "b"\ntasks = ["angles"]\n')
    assert "unknown order 'williams'" in error_of(
        ANGLES, more, '[[blocks]]\nid = "b"\ntasks = ["angles", "more"]\norder = "williams"\n')
    assert "listed in that [[blocks]] table" in error_of(ANGLES, 'block = "b"\n')


def test_duplicate_ids():
    assert "task id 'angles' is used twice" in error_of(ANGLES, ANGLES)
    question = '[[tasks.questions]]\nid = "q"\nkind = "text"\ntext = "?"\n'
    assert "question id 'q' is used twice" in error_of(ANGLES, question, question)
    more = ANGLES.replace('"angles"', '"more"')
    block = '[[blocks]]\nid = "b"\ntasks = ["angles", "more"]\n'
    assert "block id 'b' is used twice" in error_of(ANGLES, more, block, block)


def test_unknown_subtask():
    assert "contact-angle-v1 declares no subtask 'angle' (did you mean 'angles'?)" in error_of(
        ANGLES, 'subtask = "angle"\n')
    hot_wire = '[[tasks]]\nid = "wire"\nscenario = "hot-wire"\nsubtask = "trace"\n'
    assert "hot-wire-v1 declares no subtask 'trace' (it declares none)" in error_of(hot_wire)


def test_question_errors():
    def question(body: str) -> str:
        return error_of(ANGLES, f'[[tasks.questions]]\nid = "q"\ntext = "?"\n{body}')
    assert 'question "q": low (7) must be below high (7)' in question('kind = "likert"\nlow = 7\n')
    assert "low (5) must be below high (1)" in question('kind = "number"\nlow = 5\nhigh = 1\n')
    assert "needs at least 2 choices, got 1" in question('kind = "choice"\nchoices = ["only"]\n')
    assert "needs at least 2 choices, got 0" in question('kind = "choice"\n')
    assert "choices must differ" in question('kind = "choice"\nchoices = ["a", "a"]\n')
    assert "field 'choices' does not apply to a likert question" in question('kind = "likert"\nchoices = [1, 2]\n')
    assert "field 'integer' does not apply to a likert question" in question('kind = "likert"\ninteger = true\n')
    assert "unknown kind 'scale'" in question('kind = "scale"\n')
    assert "labels: 9 = 'x' must name a scale point from 1 to 7" in question('kind = "likert"\nlabels = { 9 = "x" }\n')
    assert "id must be an id" in error_of(ANGLES, '[[tasks.questions]]\nid = "Q 1"\nkind = "text"\ntext = "?"\n')


def test_type_and_consistency_errors():
    assert "repetitions must be a whole number >= 1, got '2'" in error_of(ANGLES, 'repetitions = "2"\n')
    assert "repetitions must be a whole number >= 1, got 0" in error_of(ANGLES, "repetitions = 0\n")
    assert "training_s must be a number >= 0, got -5" in error_of(ANGLES, "training_s = -5\n")
    assert "id must be an id" in error_of(ANGLES.replace('"angles"', '"Angles!"'))
    nothing = '[[tasks]]\nid = "idle"\nscenario = "contact-angle"\n'
    assert "nothing to do" in error_of(nothing)
    assert "practice trials are drawn from the conditions" in error_of(nothing, "practice = 2\ntraining_s = 5\n")
    assert "training_conditions need a training time" in error_of(
        ANGLES, "training_conditions = [{ angle_deg = 0 }]\n")
    assert "conditions[0] must be a table" in error_of(ANGLES.replace("[{ angle_deg = 10 }, ", "[1, "))
    assert "at least one [[tasks]]" in error_of("tasks = []\n")


def test_invalid_toml_and_missing_file(tmp_path):
    assert error_of(ANGLES, "order = \n").startswith("mini.toml: not valid TOML:")
    with pytest.raises(StudyError, match="cannot read the study file"):
        load_study(tmp_path / "nope.toml")
    path = tmp_path / "x.toml"
    path.write_text(HEAD + ANGLES + 'oder = "fixed"\n', encoding="utf-8")
    with pytest.raises(StudyError, match=f"^{path}: task \"angles\": unknown field"):
        load_study(path)


def test_question_built_in_code_gets_the_same_defaults():
    q = Question("rating", "likert", "How?", labels={4: "same"})
    assert (q.low, q.high, dict(q.labels)) == (1, 7, {4: "same"})
    with pytest.raises(TypeError):
        q.labels[1] = "x"
    with pytest.raises(ValueError):
        Question("x", "slider", "?")


def test_study_header_errors():
    with pytest.raises(StudyError, match="id must be an id of lower-case letters, digits, - and _, got 'My Study'"):
        parse_study(HEAD.replace('"mini"', '"My Study"') + ANGLES, "mini.toml")
    with pytest.raises(StudyError, match="participants must be a whole number >= 1, got 0"):
        parse_study(HEAD.replace("participants = 4", "participants = 0") + ANGLES, "mini.toml")


def test_the_readme_example_is_a_valid_study():
    text = (ROOT / "studies" / "README.md").read_text(encoding="utf-8")
    example = text.split("```toml\n", 1)[1].split("```", 1)[0]
    study = parse_study(example, "README.md")
    assert [t.id for t in study.tasks] == ["angles", "soft", "hard"] and study.blocks[0].tasks == ("soft", "hard")
