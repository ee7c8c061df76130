"""Study files: who answers a question (`answered_by`) and the study's audio (`[audio]`)."""

from __future__ import annotations

import pytest

from server.experiment.question import Question
from server.experiment.study import Audio
from tests.experiment.test_study import ANGLES as TASK
from tests.experiment.test_study import error_of, mini


def question(kind: str, answered_by: str | None, extra: str = "") -> str:
    line = f'answered_by = "{answered_by}"\n' if answered_by is not None else ""
    return f'[[tasks.questions]]\nid = "q"\nkind = "{kind}"\ntext = "How?"\n{line}{extra}'


def test_answered_by_defaults_to_the_experimenter_and_takes_the_participant():
    assert mini(TASK, question("likert", None)).task("angles").question("q").answered_by == "experimenter"
    q = mini(TASK, question("likert", "participant")).task("angles").question("q")
    assert q.answered_by == "participant" and q.to_dict()["answered_by"] == "participant"
    assert mini(TASK, question("choice", "participant", 'choices = ["a", "b"]\n')).task("angles").question(
        "q").answered_by == "participant"
    assert mini(TASK, question("number", "participant", "low = -90\nhigh = 90\n")).task("angles").question(
        "q").answered_by == "participant"
    assert mini(TASK, question("text", "experimenter")).task("angles").question("q").answered_by == "experimenter"


def test_answered_by_errors_name_the_question():
    assert error_of(TASK, question("likert", "participnt")) == \
        'mini.toml: task "angles": question "q": unknown answered_by \'participnt\' (did you mean \'participant\'?)'
    message = error_of(TASK, question("text", "participant"))
    assert message.startswith('mini.toml: task "angles": question "q": answered_by = "participant" needs a likert')
    assert "a text question is answered by the experimenter" in message
    assert "must be a string" in error_of(TASK, question("likert", None, "answered_by = true\n"))


def test_question_in_code_checks_answered_by():
    with pytest.raises(ValueError, match="answered_by"):
        Question("q", "likert", "?", answered_by="robot")
    with pytest.raises(ValueError, match="by choosing"):
        Question("q", "text", "?", answered_by="participant")


def test_audio_is_off_unless_the_study_turns_it_on():
    study = mini(TASK)
    assert study.audio == Audio(False, False) and study.task("angles").audio == Audio(False, False)
    study = mini('[audio]\nspeech = true\n', TASK)
    assert study.audio == Audio(speech=True, contact_sounds=False)
    assert study.task("angles").audio == Audio(speech=True, contact_sounds=False)  # the study's, inherited
    assert study.to_dict()["audio"] == {"speech": True, "contact_sounds": False}


def test_a_task_overrides_the_studys_audio_field_by_field():
    study = mini('[audio]\nspeech = true\n', TASK, "[tasks.audio]\ncontact_sounds = true\n",
                 TASK.replace('"angles"', '"quiet"'), "[tasks.audio]\nspeech = false\n")
    assert study.task("angles").audio == Audio(speech=True, contact_sounds=True)
    assert study.task("quiet").audio == Audio(speech=False, contact_sounds=False)
    assert study.task("angles").to_dict()["audio"] == {"speech": True, "contact_sounds": True}


def test_audio_errors():
    assert error_of('[audio]\nspech = true\n', TASK) == "mini.toml: audio: unknown field 'spech' (did you mean 'speech'?)"
    assert error_of('[audio]\nspeech = 1\n', TASK) == "mini.toml: audio: speech must be true or false, got 1"
    assert error_of(TASK, '[tasks.audio]\ncontact = true\n') == \
        'mini.toml: task "angles": audio: unknown field \'contact\' (did you mean \'contact_sounds\'?)'
    assert error_of('audio = "on"\n', TASK) == "mini.toml: audio: must be a table, got str"
