"""Participant-paced tasks: the `[tasks.pacing]` table of a study file, and the sans-I/O pacer
(server/experiment/pacing.py) on a hand-made clock."""

from __future__ import annotations

import pytest

from server.experiment.pacing import Decision, Pacer, Pacing, QueuedTrial
from server.experiment.study import StudyError, parse_study

STUDY = """
id = "paced"
title = "Paced"
seed = 1
participants = 1

[[tasks]]
id = "pick"
scenario = "contact-angle"
conditions = [{{ angle_deg = 10 }}, {{ angle_deg = 20 }}]
order = "fixed"
{pacing}

[[tasks.questions]]
id = "which"
kind = "choice"
text = "Which?"
choices = ["1", "2"]
answered_by = "{answered_by}"
"""


def study(pacing: str = "", answered_by: str = "participant"):
    return parse_study(STUDY.format(pacing=pacing, answered_by=answered_by), "paced.toml")


# -- the study file ----------------------------------------------------------------------------

def test_pacing_is_the_experimenters_unless_the_file_says_otherwise():
    task = study().task("pick")
    assert task.pacing == Pacing() and not task.pacing.paced
    assert task.to_dict()["pacing"] == {"by": "experimenter", "iti_ms": 800, "feedback": False, "feedback_ms": 600,
                                        "break_every": 0}


def test_a_pacing_table_is_read_with_its_values():
    task = study('[tasks.pacing]\nby = "participant"\niti_ms = 300\nfeedback = true\nfeedback_ms = 900\n'
                 "break_every = 5").task("pick")
    assert task.pacing == Pacing(by="participant", iti_ms=300, feedback=True, feedback_ms=900, break_every=5)
    assert task.pacing.paced


@pytest.mark.parametrize("table, message", [
    ('by = "participnat"', "unknown by 'participnat' (did you mean 'participant'?)"),
    ('by = "participant"\niti = 300', "unknown field 'iti' (did you mean 'iti_ms'?)"),
    ('by = "participant"\niti_ms = -1', "iti_ms must be a whole number >= 0, got -1"),
    ('by = "participant"\nbreak_every = 2.5', "break_every must be a whole number >= 0, got 2.5"),
    ('by = "participant"\nfeedback = "yes"', "feedback must be true or false, got 'yes'"),
])
def test_a_bad_pacing_table_is_refused_naming_the_field(table, message):
    with pytest.raises(StudyError) as e:
        study("[tasks.pacing]\n" + table)
    assert str(e.value).startswith('paced.toml: task "pick": pacing: ')
    assert message in str(e.value)


def test_participant_pacing_refuses_a_question_the_experimenter_answers_naming_it():
    with pytest.raises(StudyError) as e:
        study('[tasks.pacing]\nby = "participant"', answered_by="experimenter")
    assert 'task "pick"' in str(e.value) and 'question "which" is answered by the experimenter' in str(e.value)
    study('[tasks.pacing]\nby = "experimenter"', answered_by="experimenter")  # as today


# -- the pacer ---------------------------------------------------------------------------------

PACED = Pacing(by="participant", iti_ms=800)


def queue(*statuses: str, task: str = "t", answered: int | None = None, correct: dict | None = None):
    """Trials 0.. of one task with these statuses; `answered`: the seq whose answers are in."""
    correct = correct or {}
    return [QueuedTrial(seq=i, task=task, kind="main", status=s, answered=(i == answered), correct=correct.get(i))
            for i, s in enumerate(statuses)]


def test_an_answered_trial_is_finished_and_the_next_starts_after_the_inter_trial_interval():
    p = Pacer({"t": PACED})
    p.observe(0, queue("running", "pending"))
    assert p.decide(0) == Decision("idle") and p.state(0) == "trial"
    p.observe(100, queue("running", "pending", answered=0))
    assert p.decide(100) == Decision("finish", 0)
    p.observe(120, queue("answered", "pending"))      # finished at 120 ms
    assert p.decide(120) == Decision("wait", at_ms=920)
    assert p.view(500) == {"state": "next", "done": 1, "total": 2, "feedback": None}
    assert p.decide(919.9).action == "wait"
    assert p.decide(920) == Decision("start", 1)
    p.observe(930, queue("answered", "running"))
    assert p.view(930)["state"] == "trial"


def test_the_first_trial_of_a_task_waits_for_the_experimenter():
    p = Pacer({"t": PACED})
    p.observe(0, queue("pending", "pending"))
    assert p.decide(10_000) == Decision("idle")
    assert p.view(0) == {"state": "experimenter", "done": 0, "total": 2, "feedback": None}
    p.resume(50)   # the console's Resume (or Start) goes on
    assert p.decide(60) == Decision("wait", at_ms=850)
    assert p.decide(850) == Decision("start", 0)


def test_nothing_moves_without_a_console_holding_the_session():
    p = Pacer({"t": PACED})
    p.controlled = False
    p.observe(0, queue("running", "pending", answered=0))
    assert p.decide(0) == Decision("idle")
    p.controlled = True
    assert p.decide(0) == Decision("finish", 0)


def test_a_task_the_file_does_not_pace_is_left_to_the_experimenter():
    p = Pacer({"t": Pacing()})
    p.observe(0, queue("running", "pending", answered=0))
    assert p.decide(0) == Decision("idle") and p.view(0) is None


def test_pause_holds_the_next_start_and_resume_goes_on_after_the_interval():
    p = Pacer({"t": PACED})
    p.observe(0, queue("running", "pending", "pending"))
    p.observe(10, queue("answered", "pending", "pending"))
    p.pause()
    assert p.decide(5000) == Decision("idle") and p.state(5000) == "paused"
    p.resume(6000)
    assert p.decide(6000) == Decision("wait", at_ms=6800)
    assert p.decide(6800) == Decision("start", 1)


def test_a_running_trial_is_still_finished_while_paused():
    p = Pacer({"t": PACED})
    p.observe(0, queue("running", "pending"))
    p.pause()
    p.observe(10, queue("running", "pending", answered=0))
    assert p.decide(10) == Decision("finish", 0)


def test_an_aborted_trial_pauses_the_pacer():
    p = Pacer({"t": PACED})
    p.observe(0, queue("running", "pending"))
    p.observe(10, queue("aborted", "pending"))
    assert p.decide(10_000) == Decision("idle") and p.state(10_000) == "paused"


def test_a_refused_start_pauses_with_its_reason():
    p = Pacer({"t": PACED})
    p.observe(0, queue("running", "pending"))
    p.observe(10, queue("answered", "pending"))
    p.refused("trial 1 could not start: device 'ferrovibe' is disconnected")
    assert p.decide(10_000) == Decision("idle") and p.state(0) == "paused" and "ferrovibe" in p.note
    p.resume(20_000)
    assert p.note == "" and p.decide(20_800) == Decision("start", 1)


def test_feedback_shows_for_its_time_and_delays_the_next_start_when_longer():
    pacing = Pacing(by="participant", iti_ms=200, feedback=True, feedback_ms=600)
    p = Pacer({"t": pacing})
    p.observe(0, queue("running", "pending"))
    p.observe(100, queue("answered", "pending", correct={0: True}))
    assert p.view(100) == {"state": "feedback", "done": 1, "total": 2, "feedback": "correct"}
    assert p.next_change_ms(100) == 700
    assert p.decide(400) == Decision("wait", at_ms=700)
    assert p.view(700)["state"] == "next" and p.view(700)["feedback"] is None
    assert p.decide(700) == Decision("start", 1)


@pytest.mark.parametrize("feedback, correct", [(True, None), (False, False)])
def test_no_feedback_without_the_files_wish_or_without_a_known_answer(feedback, correct):
    p = Pacer({"t": Pacing(by="participant", iti_ms=200, feedback=feedback, feedback_ms=600)})
    p.observe(0, queue("running", "pending"))
    p.observe(100, queue("answered", "pending", correct={0: correct}))
    assert p.view(100)["state"] == "next" and p.view(100)["feedback"] is None
    assert p.decide(300) == Decision("start", 1)


def test_a_wrong_answer_is_fed_back_as_wrong():
    p = Pacer({"t": Pacing(by="participant", feedback=True)})
    p.observe(0, queue("running", "pending"))
    p.observe(1, queue("answered", "pending", correct={0: False}))
    assert p.view(1)["feedback"] == "wrong"


def test_a_break_every_n_trials_waits_for_the_participant_and_never_after_the_last():
    p = Pacer({"t": Pacing(by="participant", iti_ms=100, break_every=2)})
    p.observe(0, queue("running", "pending", "pending", "pending"))
    p.observe(10, queue("answered", "running", "pending", "pending"))  # (started by the experimenter)
    p.observe(20, queue("answered", "answered", "pending", "pending"))
    assert p.decide(60_000) == Decision("idle")
    assert p.view(60_000) == {"state": "break", "done": 2, "total": 4, "feedback": None}
    assert p.continue_break(61_000) is True
    assert p.continue_break(61_001) is False  # no break held any more
    assert p.decide(61_000) == Decision("wait", at_ms=61_100)
    assert p.decide(61_100) == Decision("start", 2)
    p.observe(61_100, queue("answered", "answered", "running", "pending"))
    p.observe(61_200, queue("answered", "answered", "answered", "running"))
    p.observe(61_300, queue("answered", "answered", "answered", "answered"))
    assert p.view(61_300) is None and p.decide(70_000) == Decision("idle")  # the task's end: no break


def test_resume_ends_a_break():
    p = Pacer({"t": Pacing(by="participant", iti_ms=100, break_every=1)})
    p.observe(0, queue("running", "pending"))
    p.observe(10, queue("answered", "pending"))
    assert p.state(10) == "break"
    p.pause()
    assert p.state(20) == "paused" and p.continue_break(20) is False
    p.resume(30)
    assert p.decide(130) == Decision("start", 1)


def test_continue_without_a_break_is_refused():
    p = Pacer({"t": PACED})
    p.observe(0, queue("running", "pending"))
    assert p.continue_break(0) is False


def test_the_task_end_waits_for_the_experimenter():
    p = Pacer({"a": PACED, "b": PACED})
    trials = [QueuedTrial(0, "a", "main", "running"), QueuedTrial(1, "b", "main", "pending")]
    p.observe(0, trials)
    p.observe(10, [QueuedTrial(0, "a", "main", "answered"), QueuedTrial(1, "b", "main", "pending")])
    assert p.decide(60_000) == Decision("idle") and p.state(60_000) == "experimenter"


def test_questionnaires_and_training_are_not_paced():
    p = Pacer({"t": PACED})
    p.observe(0, [QueuedTrial(0, "t", "main", "running"), QueuedTrial(1, "t", "questionnaire", "pending")])
    p.observe(10, [QueuedTrial(0, "t", "main", "answered"), QueuedTrial(1, "t", "questionnaire", "pending")])
    assert p.decide(60_000) == Decision("idle") and p.view(60_000) is None


def test_a_trial_is_answered_when_every_required_question_has_an_answer():
    row = {"seq": 3, "task": "t", "kind": "main", "status": "running", "responses": {"a": "1"}, "metrics": {}}
    assert QueuedTrial.from_session(row, ["a"]).answered
    assert not QueuedTrial.from_session(row, ["a", "b"]).answered
    assert not QueuedTrial.from_session(row, []).answered  # nothing to wait for: never finished by itself
    ended = {**row, "status": "answered", "metrics": {"psy": {"correct": True}}}
    assert QueuedTrial.from_session(ended, ["a"]).correct is True
    assert QueuedTrial.from_session({**row, "metrics": {"psy": {"correct": None}}}, ["a"]).correct is None


def test_after_a_restart_the_session_waits_for_resume_and_goes_on_at_its_next_pending_trial():
    p = Pacer({"t": PACED})  # a new pacer: the server started again; the queue is on disk
    p.observe(0, queue("answered", "answered", "pending", "pending"))
    assert p.decide(60_000) == Decision("idle")
    assert p.view(0) == {"state": "experimenter", "done": 2, "total": 4, "feedback": None}
    p.resume(1000)
    assert p.decide(1800) == Decision("start", 2)
