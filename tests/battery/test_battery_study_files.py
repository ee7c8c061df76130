"""The battery as study files (issue 38 point 1, docs/battery.md): one per device from the parts
catalogue, what a device cannot show skipped with the capability check's words (never silently
missing), the parts in a counterbalanced order, every psychophysics part participant-paced with
breaks and its minutes counting them (point 4), a lab's own part added with a study-file table, and
the checked-in files equal to what `viestac battery` writes now."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from devices.capability import check
from devices.profiles import ProfileError
from server.battery.parts import ANSWER_S, BREAK_S, CARRIERS_HZ, PACING, PARTS, POSITIONING_TRIAL_S, STRETCH_S, plan_for
from server.battery.study_file import BUILT_IN, battery_study, extra_tasks
from server.experiment.plan import plan_session, task_order
from server.experiment.psychophysics_task import device_refusal
from server.experiment.study import StudyError, load_study, parse_study

ROOT = Path(__file__).resolve().parents[2]

LAB_PART = '''
[[tasks]]
id = "pulse_rate"
title = "Pulse-rate discrimination (our lab's part)"
scenario = "stimulus"
params = { cue = "pulse_train", t_on_ms = 20, t_off_ms = 80, intensity_pct = 80, duration_ms = 600 }
[tasks.psychophysics]
design = "2ifc"
parameter = "duration_ms"
max_trials = 40
reference = 600
[tasks.psychophysics.procedure]
kind = "up-down"
scale = "log"
start = 900
steps = [1.12, 1.04]
down = 3
min = 610
max = 2000
max_trials = 40
'''


@pytest.mark.parametrize("model", BUILT_IN)
def test_the_checked_in_battery_files_are_what_the_generator_writes(model):
    path = ROOT / "studies" / f"battery-{model}.toml"
    assert path.read_text(encoding="utf-8") == battery_study(model), (
        f"regenerate: viestac battery --device {model} --out studies/battery-{model}.toml")
    study = load_study(path)
    assert study.id == f"battery-{model}"


@pytest.mark.parametrize("model", BUILT_IN)
def test_every_part_runs_or_is_listed_as_skipped_with_the_capability_checks_words(model):
    plans = plan_for(model)
    assert [p.part.id for p in plans] == [p.id for p in PARTS]
    text = battery_study(model)
    study = parse_study(text, "battery")
    tasks = {t.id: t for t in study.tasks}
    for plan in plans:
        if plan.runs:
            assert plan.part.id in tasks and plan.reason is None and plan.trials > 0 and plan.minutes > 0
            assert tasks[plan.part.id].device == model
            continue
        assert plan.part.id not in tasks and plan.trials == 0
        assert f"#   {plan.part.id}: {plan.reason}" in text, "a skipped part is listed with its reason"
        # the reason is the study loader's own refusal of that task on this device
        params = {"cue": {"frequency_jnd": "vibration", "temperature_change": "temperature"}.get(plan.part.id, "tilt")}
        refused = device_refusal(plan.part.parameter, params, model)
        assert refused is not None and refused[1] == plan.reason
    # the one skip reason of positioning would come from the scenarios' capability check
    assert check("positioning-v1", (), {}).ok


def test_what_each_device_runs_follows_its_profile():
    runs = {m: {p.part.id for p in plan_for(m) if p.runs} for m in BUILT_IN}
    common = {"detection", "amplitude_jnd", "texture_period", "stiffness", "positioning"}
    assert runs["fingertac"] == common
    assert runs["ferrovibe"] == common | {"tilt_direction", "angle_identification"}
    assert runs["devkit"] == common | {"temperature_change"}
    assert runs["audio"] == common | {"frequency_jnd"}


def test_detection_is_an_interleaved_staircase_per_carrier_where_the_device_can_vary_it():
    audio = load_study(ROOT / "studies" / "battery-audio.toml").task("detection").psychophysics
    assert list(audio.conditions) == [f"f{c}" for c in CARRIERS_HZ]
    assert [dict(v)["carrier_hz"] for v in audio.conditions.values()] == list(CARRIERS_HZ)
    fixed = load_study(ROOT / "studies" / "battery-fingertac.toml").task("detection").psychophysics
    assert list(fixed.conditions) == ["f235"]  # the FingerTac's LRAs play their own carrier only


def test_the_parts_run_in_a_balanced_latin_order_and_a_battery_fits_in_about_an_hour():
    for model in BUILT_IN:
        study = load_study(ROOT / "studies" / f"battery-{model}.toml")
        ids = [t.id for t in study.tasks]
        assert [b.tasks for b in study.blocks] == [tuple(ids)] and study.blocks[0].order == "latin"
        orders = [tuple(t.id for t in task_order(study, i)) for i in range(len(ids))]
        assert len(set(orders)) == len(ids)  # every participant of a square's rows has its own order
        for position in range(len(ids)):  # each part once in each position
            assert sorted(o[position] for o in orders) == sorted(ids)
        assert 10 <= sum(p.minutes for p in plan_for(model) if p.runs) <= 60


@pytest.mark.parametrize("model", BUILT_IN)
def test_every_psychophysics_part_is_participant_paced_with_a_break_at_least_every_five_minutes(model):
    path = ROOT / "studies" / f"battery-{model}.toml"
    study = load_study(path)
    assert STRETCH_S <= 5 * 60
    for plan in (p for p in plan_for(model) if p.runs):
        task = study.task(plan.part.id)
        if plan.part.id == "positioning":  # its trials end at an insertion, not an answer: the experimenter's
            assert not task.pacing.paced and plan.breaks == 0
            assert plan.minutes == round((plan.trials + task.practice) * POSITIONING_TRIAL_S / 60, 1)
            continue
        pacing, params = task.pacing, task.params
        assert pacing.paced and not pacing.feedback and pacing.iti_ms == PACING["iti_ms"]
        n = task.psychophysics.design.intervals
        trial_s = ((params["lead_ms"] + n * params["duration_ms"] + (n - 1) * params["isi_ms"]) / 1000
                   + ANSWER_S + pacing.iti_ms / 1000)  # a trial, start to start: stimulus, answer, interval
        # the most trials that fit in the stretch: no stretch longer, one trial more would be
        assert pacing.break_every * trial_s <= STRETCH_S < (pacing.break_every + 1) * trial_s
        paced = plan.trials + task.practice  # the pacer paces and counts the practice trials too
        assert plan.breaks == (paced - 1) // pacing.break_every  # never after the last trial
        assert plan.minutes == round((paced * trial_s + plan.breaks * BREAK_S) / 60, 1)
    text = path.read_text(encoding="utf-8")
    assert "# waits for the experimenter to start the next part (a natural break)." in text
    assert "# experimenter-paced: its trials end at an insertion" in text


def test_a_lab_adds_its_own_part_with_a_study_file_table_not_code(tmp_path):
    text = battery_study("fingertac", extra_tasks(LAB_PART))
    study = parse_study(text, "battery-fingertac.toml")
    task = study.task("pulse_rate")
    assert task.psychophysics.parameter == "duration_ms" and task.block == "battery"
    assert "pulse_rate" in study.blocks[0].tasks
    assert any(t.task == "pulse_rate" for t in plan_session(study, 0))
    # the command line does the same from a file
    extra, out = tmp_path / "ours.toml", tmp_path / "battery.toml"
    extra.write_text(LAB_PART, encoding="utf-8")
    done = subprocess.run([sys.executable, "-m", "server.cli", "battery", "--device", "fingertac", "--out", str(out),
                           "--add", str(extra)], capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    assert out.read_text(encoding="utf-8") == text
    assert re.search(r"frequency_jnd\s+skipped: device fingertac has a fixed carrier", done.stdout)


def test_a_bad_lab_part_or_device_is_refused_with_a_clear_error(tmp_path):
    with pytest.raises(StudyError, match="pulse_rate.*duration_ms levels must stay within"):
        battery_study("fingertac", extra_tasks(LAB_PART.replace("max = 2000", "max = 90000")))
    with pytest.raises(ValueError, match="built-in part has that id"):
        battery_study("fingertac", extra_tasks(LAB_PART.replace('id = "pulse_rate"', 'id = "stiffness"')))
    with pytest.raises(ValueError, match="only \\[\\[tasks\\]\\] tables"):
        extra_tasks('id = "x"\n' + LAB_PART)
    with pytest.raises(ProfileError, match="no built-in profile 'nope'"):
        plan_for("nope")
    out = tmp_path / "x.toml"
    done = subprocess.run([sys.executable, "-m", "server.cli", "battery", "--device", "nope", "--out", str(out)],
                          capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 2 and "no built-in profile 'nope'" in done.stderr and not out.exists()
