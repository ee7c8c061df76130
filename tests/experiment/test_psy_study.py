"""`[tasks.psychophysics]` in a study file (server/experiment/study.py, psychophysics_task.py):
what loads, and the refusals at load, each naming the field; every file in studies/ loads."""

from pathlib import Path

import pytest

from server.experiment.plan import plan_session
from server.experiment.study import StudyError, load_study, parse_study

STUDIES = Path(__file__).resolve().parents[2] / "studies"
BASE = '''id = "x"
title = "x"
seed = 1
participants = 2

[[tasks]]
id = "detect"
scenario = "stimulus"
params = { cue = "vibration" }
practice = 2

[tasks.psychophysics]
design = "2ifc"
parameter = "intensity_pct"
max_trials = 20

[tasks.psychophysics.procedure]
kind = "up-down"
scale = "db"
start = 50
steps = [6, 3]
min = 1
max = 100
max_trials = 20
'''
PREFIX = 'studies/x.toml: task "detect": '


def study(*edits, add_task="", add_psy="", add_procedure=""):
    text = BASE
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new)
    text = text.replace("practice = 2\n", f"practice = 2\n{add_task}\n")
    text = text.replace("max_trials = 20\n\n", f"max_trials = 20\n{add_psy}\n\n", 1)
    return parse_study(text + add_procedure + "\n", "studies/x.toml")


def refusal(*edits, **adds) -> str:
    with pytest.raises(StudyError) as err:
        study(*edits, **adds)
    return str(err.value)


def test_a_psychophysics_task_loads_with_its_generated_question_and_plans_its_reserve(stimulus):
    s = study()
    task = s.task("detect")
    psy = task.psychophysics
    assert psy.design.name == "2ifc" and psy.design.choices == ("1", "2") and psy.design.guess == 0.5
    assert psy.parameter == "intensity_pct" and psy.unit == "%" and psy.max_trials == 20
    assert psy.procedure.kind == "up-down" and psy.procedure.target == pytest.approx(0.5 ** 0.5)
    (q,) = task.questions
    assert (q.id, q.kind, q.choices, q.answered_by, q.required) == ("response", "choice", ("1", "2"), "participant",
                                                                     True)
    plan = plan_session(s, 0)
    assert [p.kind for p in plan] == ["trial"] * 2 + ["main"] * 20
    assert all(p.params == {"parameter": "intensity_pct", "n_intervals": 2, "level_1": None, "level_2": None,
                            "level_3": None, "level_4": None} for p in plan)
    assert task.to_dict()["psychophysics"]["design"] == "2ifc"


def test_the_designs_answers(stimulus):
    assert study(("design = \"2ifc\"", 'design = "yes-no"'),
                 add_psy="catch_rate = 0.25").task("detect").psychophysics.design.choices == ("yes", "no")
    nafc = study(("design = \"2ifc\"", 'design = "nafc"\nintervals = 4')).task("detect").psychophysics.design
    assert nafc.choices == ("1", "2", "3", "4") and nafc.guess == 0.25 and nafc.intervals == 4
    same = study(("design = \"2ifc\"", 'design = "same-different"\nreference = 20')).task("detect").psychophysics
    assert same.design.choices == ("same", "different") and same.design.reference == 20


def test_identification_labels_its_constant_levels(stimulus):
    text = BASE.replace('design = "2ifc"', 'design = "identification"\nlabels = ["weak", "mid", "strong"]')
    text = text[:text.index("[tasks.psychophysics.procedure]")] + \
        '[tasks.psychophysics.procedure]\nkind = "constant"\nlevels = [10, 40, 90]\nrepeats = 4\n'
    design = parse_study(text, "studies/x.toml").task("detect").psychophysics.design
    assert design.choices == ("weak", "mid", "strong") and design.stimuli == (10.0, 40.0, 90.0)
    assert design.guess == pytest.approx(1 / 3)
    with pytest.raises(StudyError, match=r'psychophysics: labels: identification needs at least 2 answers, got 0'):
        parse_study(text.replace('labels = ["weak", "mid", "strong"]', "labels = []"), "studies/x.toml")
    with pytest.raises(StudyError, match=r"labels: one label per stimulus level: 3 levels, 2 labels"):
        parse_study(text.replace('labels = ["weak", "mid", "strong"]', 'labels = ["a", "b"]'), "studies/x.toml")


def test_an_unknown_procedure_is_refused_with_did_you_mean(stimulus):
    assert refusal(('kind = "up-down"', 'kind = "up-dwon"')) == (
        PREFIX + "psychophysics: procedure: kind: unknown procedure 'up-dwon' (did you mean 'up-down'?)")


def test_steps_that_cannot_converge_are_refused(stimulus):
    # a 1-up/1-down track converges to 50 % correct: the 2IFC guess rate, so it cannot converge
    assert refusal(add_procedure="down = 1") == (
        PREFIX + "psychophysics: procedure: down: a 1-up/1-down track converges to p = 0.500, not above the guess "
                 "rate 0.5: it cannot converge")
    assert "psychophysics: procedure: steps: every value must be > 0" in refusal(("steps = [6, 3]", "steps = [0]"))
    # the guess rate comes from the design: yes-no has none, so the same track loads there
    assert study(('design = "2ifc"', 'design = "yes-no"'), add_procedure="down = 1")


def test_a_level_outside_the_devices_range_is_refused(stimulus):
    assert refusal(("max = 100", "max = 150")) == (
        PREFIX + "psychophysics: procedure: max: intensity_pct levels must stay within [0, 100] % (the vibration "
                 "cue's range); got 150")
    assert refusal(("max = 100\n", "")).endswith("procedure: max: intensity_pct levels must stay within [0, 100] % "
                                                 "(the vibration cue's range); missing: the procedure could step past 100")
    carrier = refusal(('parameter = "intensity_pct"', 'parameter = "carrier_hz"'), ("start = 50", "start = 200"),
                      ("max = 100", "max = 400"), add_task='device = "fingertac"')
    assert carrier == (PREFIX + "psychophysics: parameter: device fingertac has a fixed carrier (235 Hz), no carrier "
                                "range for carrier_hz levels (a broadband tactor on a sound interface has one)")
    # the same levels on a voice-coil tactor (a carrier range) load
    assert study(('parameter = "intensity_pct"', 'parameter = "carrier_hz"'), ("start = 50", "start = 200"),
                 ("max = 100", "max = 400"), add_task='device = "audio"')
    assert refusal(add_psy="practice_levels = [120]").endswith(
        "psychophysics: practice_levels: intensity_pct levels must stay within [0, 100] % (the vibration cue's "
        "range); got 120")
    assert refusal(('parameter = "intensity_pct"', 'parameter = "direction_deg"'), ('cue = "vibration"', 'cue = "tilt"'),
                   add_task='device = "fingertac"').endswith(
        "psychophysics: parameter: device fingertac cannot show a tilt cue (it accepts continuous, pulse, texture)")


def test_a_design_with_no_answer_keys_or_too_few_choices_is_refused(stimulus):
    assert refusal(('design = "2ifc"', 'design = "nafc"\nintervals = 1')) == (
        PREFIX + "psychophysics: intervals: an nAFC trial needs 2 to 4 intervals (one answer key each), got 1")
    assert refusal(('design = "2ifc"', 'design = "nafc"\nintervals = 5')).endswith("got 5")
    assert refusal(('design = "2ifc"', 'design = "2afc"')) == (
        PREFIX + "psychophysics: design: unknown value '2afc' (did you mean 'nafc'?)")
    assert refusal(('design = "2ifc"', 'design = "identification"\nlabels = ["a", "b"]')).endswith(
        'procedure: identification presents k fixed stimuli: kind = "constant" with their levels, not \'up-down\'')


def test_a_parameter_the_stimulus_scenario_does_not_have_is_refused(stimulus):
    assert refusal(('parameter = "intensity_pct"', 'parameter = "intensity"')) == (
        PREFIX + "psychophysics: parameter: unknown value 'intensity' (did you mean 'intensity_pct'?)")
    assert refusal(('parameter = "intensity_pct"', 'parameter = "carrier_hz"'),
                   ('cue = "vibration"', 'cue = "texture"')).endswith(
        "psychophysics: parameter: a texture cue has no carrier_hz (cues that have it: pulse_train, vibration)")


def test_other_refusals_name_their_field(stimulus):
    assert refusal(add_psy="max_trial = 3") == (
        PREFIX + "psychophysics: unknown field 'max_trial' (did you mean 'max_trials'?)")
    assert refusal(add_psy="catch_rate = 0.2").endswith("psychophysics: catch_rate: applies to a yes-no design, not 2ifc")
    assert refusal(("max_trials = 20\n\n", "\n\n")).endswith("psychophysics: max_trials: missing (required)")
    assert refusal(add_task='conditions = [{ parameter = "intensity_pct" }]').startswith(
        PREFIX + "conditions: a psychophysics task's trials come from its procedure")
    assert refusal(('scenario = "stimulus"', 'scenario = "free"'),
                   ('params = { cue = "vibration" }', "")) == (
        PREFIX + 'psychophysics: a psychophysics task presents with scenario = "stimulus", not free-v1')
    assert refusal(('design = "2ifc"', 'design = "same-different"')).endswith(
        "psychophysics: reference: missing (required): a same-different pair compares the level with it")
    assert refusal(add_psy="[tasks.psychophysics.conditions.f100]\ncarrier_hz = 100").endswith(
        'psychophysics: conditions: fixed params per condition need an interleaved procedure (kind = "interleaved")')


def test_interleaved_conditions_are_checked_by_name_and_against_the_device(stimulus):
    text = (STUDIES / "vt-interleaved-carrier.toml").read_text()
    assert "did you mean 'f250'" in _error(text.replace("conditions.f250]\ncarrier_hz", "conditions.f205]\ncarrier_hz"))
    assert _error(text.replace('device = "audio"', 'device = "fingertac"')).endswith(
        'psychophysics: carrier_hz: condition "f100": device fingertac has a fixed carrier (235 Hz); it cannot play '
        "100 Hz")
    assert _error(text.replace("carrier_hz = 100", "carrier_hz = 5000")).startswith(
        'studies/x.toml: task "detect": psychophysics: conditions.f100: ')


def _error(text: str) -> str:
    with pytest.raises(StudyError) as err:
        parse_study(text, "studies/x.toml")
    return str(err.value)


@pytest.mark.parametrize("path", sorted(STUDIES.glob("*.toml")), ids=lambda p: p.name)
def test_every_study_file_loads_and_plans(path, stimulus):
    s = load_study(path)
    assert plan_session(s, 0) and plan_session(s, 1)


def test_one_example_study_per_design(stimulus):
    designs = {}
    for path in sorted(STUDIES.glob("vt-*.toml")):  # the examples (the batteries are tests/battery's)
        for task in load_study(path).tasks:
            if task.psychophysics is not None:
                designs.setdefault(task.psychophysics.design.name, []).append(
                    (task.psychophysics.procedure_kind, task.psychophysics.parameter, task.device))
    assert set(designs) == {"yes-no", "nafc", "2ifc", "same-different", "identification"}
    assert ("interleaved", "intensity_pct", "audio") in designs["2ifc"]
    assert ("up-down", "intensity_pct", "fingertac") in designs["2ifc"]
    assert designs["nafc"][0][0] == "quest-plus"
    assert designs["identification"] == [("constant", "contact_angle_deg", "ferrovibe")]
