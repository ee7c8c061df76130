"""`viestac study --simulate` and `--power` on a psychophysics study: the psychometric participant
answers through the real engine (the level and design come from start()'s `psy`, Contract C2), a
finished procedure's reserved trials are skipped, and the threshold table comes from the recorded
estimates.

The engine's psychophysics (Contracts C1 and C2: the stimulus scenario, `[tasks.psychophysics]`,
start()'s `psy`) is built on another branch: these tests skip, saying so, only while it is absent."""

from __future__ import annotations

import json
import sqlite3
import textwrap

import pytest

from scenarios import registry
from server.experiment.study import StudyError, load_study
from server.simulate.study_run import psychophysics_record, simulate_study, stimulus_of
from server.synthetic import SyntheticParticipant

STUDY = textwrap.dedent("""
    id = "psy-sim"
    title = "2IFC detection for the simulator"
    seed = 3
    participants = 2

    [[tasks]]
    id = "detect"
    scenario = "stimulus"
    device = "fingertac"
    params = { cue = "vibration", duration_ms = 50, isi_ms = 50, lead_ms = 50 }
    practice = 0
    training_s = 0

    [tasks.psychophysics]
    design = "2ifc"
    parameter = "intensity_pct"
    max_trials = 14

    [tasks.psychophysics.procedure]
    kind = "up-down"
    scale = "db"
    start = 20.0
    steps = [4, 2]
    min = 0.1
    max = 100.0
    max_trials = 10
""")
PROCEDURE_TRIALS, RESERVED = 10, 14


def participant(seed, index):
    return SyntheticParticipant(seed, participant=index)


def psy_absent(study_path) -> str | None:
    """Why the engine cannot run psychophysics yet (None: it can)."""
    try:
        registry.resolve("stimulus")
    except KeyError as exc:
        return f"the engine's psy is absent: no stimulus scenario (Contract C1) on this branch: {exc}"
    try:
        load_study(study_path)
    except StudyError as exc:
        if "unknown field 'psychophysics'" in str(exc):
            return f"the engine's psy is absent: the study loader does not know [tasks.psychophysics] (Contract C2): {exc}"
        raise
    return None


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    root = tmp_path_factory.mktemp("psy-sim")
    study = root / "studies" / "psy-sim.toml"
    study.parent.mkdir()
    study.write_text(STUDY, encoding="utf-8")
    reason = psy_absent(study)
    if reason:
        pytest.skip(reason)
    try:
        result = simulate_study(study, participants=2, seed=9, out_dir=root / "run", make_participant=participant)
    except RuntimeError as exc:
        if "without a 'psy' record" in str(exc):
            pytest.skip(f"the engine's psy is absent: {exc}")
        raise
    return study, result


def test_a_main_stimulus_trial_without_psy_is_refused_naming_the_contract():
    started = {"seq": 3, "task": "detect", "kind": "main", "scenario": "stimulus-v1", "questions": ["response"]}
    with pytest.raises(RuntimeError, match="Contract C2"):
        psychophysics_record(started)
    assert psychophysics_record({**started, "psy": {"design": "2ifc"}}) == {"design": "2ifc"}
    assert psychophysics_record({**started, "scenario": "contact-angle-v1"}) is None  # other tasks as before
    assert psychophysics_record({**started, "kind": "trial"}) is None  # a practice trial may come without


def test_the_psychometric_participant_answers_every_procedure_trial(simulated):
    _, result = simulated
    con = sqlite3.connect(result.data_dir / "viestac.sqlite")
    rows = con.execute("""SELECT s.participant_index, t.seq, t.status, t.reason, t.device, t.params_json,
                                 t.scenario_params_json, t.metrics_json, r.value_json
                          FROM trials t JOIN sessions s ON s.id = t.session_id
                          LEFT JOIN responses r ON r.trial_id = t.id AND r.question = 'response'
                          WHERE t.task = 'detect' AND t.kind = 'main' ORDER BY s.participant_index, t.seq""").fetchall()
    con.close()
    assert len(rows) == 2 * RESERVED
    for index in (0, 1):
        mine = [r for r in rows if r[0] == index]
        answered = [r for r in mine if r[2] == "answered"]
        assert len(answered) == PROCEDURE_TRIALS
        assert all(r[2] == "excluded" and r[3] == "procedure finished" for r in mine[PROCEDURE_TRIALS:])
        person = participant(9, index)
        for _, seq, _, _, device, params, scenario_params, metrics, value in answered:
            psy = json.loads(metrics)["psy"]
            answer = json.loads(value)
            trial = {"seq": seq, "device": device, "params": json.loads(params),
                     "scenario_params": json.loads(scenario_params)}
            stimulus = stimulus_of(trial)
            assert stimulus["carrier_hz"] == 235.0  # the FingerTac's own carrier: the file gives none
            assert answer == psy["answer"] == person.answer_psychophysics(trial, psy, stimulus=stimulus)
            assert psy["correct"] == (answer == psy["choices"][psy["target"] - 1])
    assert result.aborted == []


def test_power_gives_the_threshold_se_per_trial_count_and_resumes(simulated, tmp_path):
    from server.simulate.threshold_power import run_threshold_power

    study, _ = simulated
    first = run_threshold_power(study, 2, 2, out=tmp_path / "power", trials=[5, 10], seed=4, workers=1)
    assert (first.computed, first.reused) == (2, 0)
    doc = json.loads((tmp_path / "power" / "threshold_power.json").read_text())
    rows = {r["trials"]: r for r in doc["rows"]}
    assert sorted(rows) == [5, 10] and rows[10]["observers"] == 4 and rows[10]["scale"] == "dB"
    assert rows[10]["estimated"] >= 1
    assert (tmp_path / "power" / "threshold_power.png").exists()
    again = run_threshold_power(study, 2, 2, out=tmp_path / "power", trials=[5, 10], seed=4, workers=1)
    assert (again.computed, again.reused) == (0, 2) and again.table == first.table
    with pytest.raises(ValueError, match="max_trials = 14"):
        run_threshold_power(study, 2, 1, out=tmp_path / "other", trials=[20])
