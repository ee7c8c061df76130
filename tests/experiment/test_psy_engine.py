"""Psychophysics tasks in the experiment engine (server/experiment/engine.py with
server/experiment/psychophysics_task.py): the real store, the real loop core behind a virtual hub,
the example study files. Each trial's level is a replay of the recorded answers, so a fresh engine
on the same database (after a crash too) presents exactly what the first one would have."""

from pathlib import Path

import pytest

from devices.profiles import profile_by_model
from server.experiment.engine import Experiment
from server.experiment.store import Conflict, Store
from server.psychophysics.designs import outcome, Presentation
from server.psychophysics.procedures import next_level
from server.simulate.virtual_device import VirtualDevice
from server.simulate.virtual_hub import VirtualHub
from tests.experiment.test_store import clock

STUDIES = Path(__file__).resolve().parents[2] / "studies"
C3_KEYS = {"design", "condition", "parameter", "unit", "level", "reference", "target", "signal", "stimulus_index",
           "choices", "answer", "answer_index", "correct", "guess", "trial", "reversal", "procedure", "estimate"}
ANSWER_KEYS = {"answer", "answer_index", "correct", "procedure", "estimate", "reversal"}


def engine(tmp_path, model="fingertac"):
    store = Store(tmp_path / "db.sqlite", clock())
    hub = VirtualHub({model: VirtualDevice(model, profile_by_model(model))})
    return Experiment(store, hub, studies_dir=STUDIES, software_version="t", config={}, record_every=10), store


def observer(threshold):
    """A deterministic observer: right above `threshold`, wrong below (wrong = the other choice)."""
    def answer(psy):
        if psy["design"] in ("2ifc", "nafc"):
            right = str(psy["target"])
            return right if psy["level"] >= threshold else next(c for c in psy["choices"] if c != right)
        if psy["design"] == "yes-no":
            return "yes" if psy["signal"] and psy["level"] >= threshold else "no"
        if psy["design"] == "same-different":
            return "different" if psy["signal"] and psy["level"] >= threshold else "same"
        return psy["choices"][psy["stimulus_index"]] if psy["level"] >= threshold else psy["choices"][0]
    return answer


def run(experiment, sid, token, answer, n=None, hub_ticks=5):
    """Start, answer (as the participant) and finish the next trials; the started trials' dicts."""
    done = []
    while n is None or len(done) < n:
        nxt = experiment.session(sid)["next"]
        if nxt is None:
            break
        started = experiment.start(sid, token, nxt)
        experiment.hub.advance(hub_ticks)
        experiment.participant_answer(sid, nxt, "response", answer(started["psy"]))
        experiment.finish(sid, token, nxt)
        done.append(started)
    return done


def recorded_outcomes(store, sid, task):
    """What the procedure heard, from the database alone: each answered main trial's answer to
    what it presented (the trial's stored C1 params and C3 record)."""
    from server.psychophysics.designs import Design
    out = []
    for t in store.trials(sid):
        if t.task == task and t.kind == "main" and "psy" in t.metrics:
            psy = t.metrics["psy"]
            design = Design(psy["design"], t.params["n_intervals"], tuple(psy["choices"]), psy["reference"])
            heard = outcome(design, Presentation((), psy["target"], psy["signal"], psy["stimulus_index"]),
                            store.responses(t.id)["response"])
            if heard is not None:
                out.append(heard)
    return out


def test_a_2ifc_staircase_presents_the_replayed_level_records_c3_and_excludes_the_rest(tmp_path, stimulus):
    experiment, store = engine(tmp_path)
    session = experiment.create_session(study_id="vt-2ifc-staircase", participant="P01", experimenter="alice")
    sid, token = session["id"], session["token"]
    study = experiment.study("vt-2ifc-staircase")
    psy = study.task("detect").psychophysics
    trials = run(experiment, sid, token, observer(12.0))
    practice = [t for t in trials if t["kind"] == "trial"]
    main = [t for t in trials if t["kind"] == "main"]
    assert [t["psy"]["level"] for t in practice] == [80.0, 80.0], "practice at the declared easy level"
    assert 10 <= len(main) < psy.max_trials, "the staircase stops on its reversals before the reserve runs out"
    from server.psychophysics.procedures import replay
    from server.experiment.psychophysics_task import Seeds
    seed = Seeds(study.seed, 0, "detect").procedure()
    rows = [t for t in store.trials(sid) if t.kind == "main"]
    heard = recorded_outcomes(store, sid, "detect")
    for k, started in enumerate(main):
        assert set(started["psy"]) == C3_KEYS - ANSWER_KEYS
        assert started["psy"]["level"] == pytest.approx(next_level(psy.procedure, heard[:k], seed))
        levels = [started["params"][f"level_{i}"] for i in (1, 2)]
        target = started["psy"]["target"]
        assert levels[target - 1] == started["psy"]["level"] and levels[2 - target] is None  # blank reference
        assert started["params"]["parameter"] == "intensity_pct" and started["params"]["n_intervals"] == 2
        row = rows[k]
        assert row.params == started["params"], "the trial row keeps what was presented (the export shows it)"
        c3 = row.metrics["psy"]
        assert set(c3) == C3_KEYS and c3["answer"] == store.responses(row.id)["response"]
        assert c3["correct"] == (c3["answer"] == str(target)) and c3["guess"] == 0.5 and c3["trial"] == k
        after = replay(psy.procedure, heard[:k + 1], seed)
        assert c3["procedure"] == after.record() and c3["estimate"] == after.estimate()
        assert c3["reversal"] == (len(after.reversals) > len(replay(psy.procedure, heard[:k], seed).reversals))
    assert {t["seq"] for t in main} == {r.seq for r in rows if r.status == "answered"}
    rest = [r for r in rows if r.status != "answered"]
    assert rest and all(r.status == "excluded" and r.reason == "procedure finished" for r in rest)
    view = experiment.session(sid)
    assert view["next"] is None and view["status"] == "completed"
    assert replay(psy.procedure, heard, seed).finished
    store.close()


def test_a_fresh_engine_on_the_same_database_presents_the_same_next_trial(tmp_path, stimulus):
    experiment, store = engine(tmp_path)
    session = experiment.create_session(study_id="vt-2ifc-staircase", participant="P02", experimenter="alice")
    sid, token = session["id"], session["token"]
    run(experiment, sid, token, observer(20.0), n=9)
    nxt = store.trial_at(sid, experiment.session(sid)["next"])
    expected = experiment._psy_next(nxt)  # what this engine would present next (no side effect)
    store.close()

    store = Store(tmp_path / "db.sqlite", clock())  # a restart: nothing kept in memory
    again = Experiment(store, VirtualHub({"fingertac": VirtualDevice("fingertac", profile_by_model("fingertac"))}),
                       studies_dir=STUDIES, software_version="t", config={})
    token = again.take_control(sid, "alice")
    started = again.start(sid, token, nxt.seq)
    assert started["psy"] == expected["psy"] and started["params"] == expected["params"]
    store.close()


def test_a_trial_interrupted_by_a_crash_presents_the_same_again(tmp_path, stimulus):
    experiment, store = engine(tmp_path)
    session = experiment.create_session(study_id="vt-2ifc-staircase", participant="P03", experimenter="alice")
    sid, token = session["id"], session["token"]
    run(experiment, sid, token, observer(20.0), n=6)
    seq = experiment.session(sid)["next"]
    first = experiment.start(sid, token, seq)
    experiment.participant_answer(sid, seq, "response", "1")  # answered, not finished: then the crash
    store.close()

    store = Store(tmp_path / "db.sqlite", clock())
    assert [t.seq for t in store.interrupted] == [seq]
    again = Experiment(store, VirtualHub({"fingertac": VirtualDevice("fingertac", profile_by_model("fingertac"))}),
                       studies_dir=STUDIES, software_version="t", config={})
    token = again.take_control(sid, "alice")
    second = again.start(sid, token, seq)
    assert second["psy"] == first["psy"] and second["params"] == first["params"] and second["attempt"] == 2
    store.close()


def test_an_answer_that_moved_the_procedure_on_cannot_change(tmp_path, stimulus):
    experiment, store = engine(tmp_path)
    session = experiment.create_session(study_id="vt-2ifc-staircase", participant="P04", experimenter="alice")
    sid, token = session["id"], session["token"]
    trials = run(experiment, sid, token, observer(20.0), n=3)
    seq = trials[-1]["seq"]
    with pytest.raises(Conflict, match="next level"):
        experiment.answer(sid, token, seq, "response", "2", "alice")
    store.close()


def test_interleaved_staircases_fix_each_conditions_carrier_and_track_each(tmp_path, stimulus):
    experiment, store = engine(tmp_path)  # the virtual rig need not be the audio tactor the file names
    session = experiment.create_session(study_id="vt-interleaved-carrier", participant="P05", experimenter="alice")
    sid, token = session["id"], session["token"]
    trials = run(experiment, sid, token, observer(15.0), n=24)
    carriers = {"f100": 100.0, "f250": 250.0, "f400": 400.0}
    per_condition = {}
    for t in trials:
        condition = t["psy"]["condition"]
        assert t["scenario_params"]["carrier_hz"] == carriers[condition]
        assert t["psy"]["trial"] == per_condition.get(condition, 0), "counted within its own staircase"
        per_condition[condition] = per_condition.get(condition, 0) + 1
    assert set(per_condition) == set(carriers)
    assert experiment.hub.scenario_target["params"]["carrier_hz"] == trials[-1]["scenario_params"]["carrier_hz"]
    tracks = experiment.tracks(sid)
    (task,) = tracks["tasks"]
    assert task["task"] == "detect" and task["procedure"] == "interleaved" and task["unit"] == "%"
    assert [c["name"] for c in task["conditions"]] == ["f100", "f250", "f400"]
    assert sum(len(c["trials"]) for c in task["conditions"]) == 24
    seqs = {t["seq"]: t for t in trials}
    for c in task["conditions"]:
        for row in c["trials"]:
            assert seqs[row["seq"]]["psy"]["condition"] == c["name"]
            assert row["level"] == seqs[row["seq"]]["psy"]["level"]
            assert set(row) == {"seq", "level", "answer", "correct", "reversal"}
    store.close()


def test_yes_no_catch_trials_present_nothing_and_do_not_move_the_procedure(tmp_path, stimulus):
    experiment, store = engine(tmp_path)
    session = experiment.create_session(study_id="vt-yes-no", participant="P06", experimenter="alice")
    sid, token = session["id"], session["token"]
    trials = [t for t in run(experiment, sid, token, observer(10.0), n=33) if t["kind"] == "main"]
    catch = [t for t in trials if not t["psy"]["signal"]]
    assert 2 <= len(catch) <= 14, "about a fifth are catch trials"
    assert all(t["params"]["level_1"] is None and t["params"]["n_intervals"] == 1 for t in catch)
    signal = [t for t in trials if t["psy"]["signal"]]
    assert all(t["params"]["level_1"] == t["psy"]["level"] for t in signal)
    assert [t["psy"]["trial"] for t in signal] == list(range(len(signal))), "catch trials are not procedure trials"
    rows = {r.seq: r for r in store.trials(sid)}
    assert all(rows[t["seq"]].metrics["psy"]["correct"] is True for t in catch), "a 'no' to nothing is correct"
    assert {rows[t["seq"]].metrics["psy"]["guess"] for t in trials} == {0.0}
    store.close()


def test_identification_presents_one_of_its_levels_and_scores_the_label(tmp_path, stimulus):
    experiment, store = engine(tmp_path, "ferrovibe")
    session = experiment.create_session(study_id="vt-identification-angle", participant="P07", experimenter="alice")
    sid, token = session["id"], session["token"]
    trials = run(experiment, sid, token, observer(0.0), hub_ticks=5)
    main = [t for t in trials if t["kind"] == "main"]
    assert len(main) == 30
    levels = [-60.0, -30.0, 0.0, 30.0, 60.0]
    assert sorted(t["psy"]["level"] for t in main) == sorted(levels * 6)
    rows = {r.seq: r for r in store.trials(sid)}
    for t in main:
        c3 = rows[t["seq"]].metrics["psy"]
        assert levels[c3["stimulus_index"]] == c3["level"] == t["params"]["level_1"]
        assert c3["correct"] == (c3["answer_index"] == c3["stimulus_index"])
        assert c3["correct"] == (c3["level"] >= 0.0) or c3["stimulus_index"] == 0
    assert experiment.session(sid)["status"] == "completed"
    store.close()


def test_the_export_shows_what_each_trial_presented(tmp_path, stimulus):
    import csv
    import json

    from server.experiment.export import export
    experiment, store = engine(tmp_path)
    session = experiment.create_session(study_id="vt-2ifc-staircase", participant="P08", experimenter="alice")
    sid, token = session["id"], session["token"]
    started = {t["seq"]: t for t in run(experiment, sid, token, observer(20.0), n=6)}
    [summary] = export(store.path, tmp_path / "out", sid)
    with open(Path(summary["dir"]) / "trials_wide.csv", newline="", encoding="utf-8") as f:
        rows = {int(r["seq"]): r for r in csv.DictReader(f)}
    for seq, t in started.items():
        row = rows[seq]
        for k in (1, 2):
            value = t["params"][f"level_{k}"]
            assert row[f"param.level_{k}"] == ("" if value is None else str(value))
        c3 = json.loads(row["metric.psy"])
        assert c3["level"] == t["psy"]["level"] and c3["target"] == t["psy"]["target"]
    assert all(rows[s]["param.level_1"] == "" and rows[s]["status"] == "pending" for s in rows if s not in started)
    store.close()


def test_tracks_are_scoped_like_the_session_and_list_only_psychophysics_tasks(tmp_path, stimulus):
    from server.experiment.engine import NotFound
    experiment, store = engine(tmp_path)
    mine = experiment.create_session(study_id="vt-2ifc-staircase", participant="P09", experimenter="alice",
                                     site="lab-a")
    run(experiment, mine["id"], mine["token"], observer(20.0), n=4)
    assert [len(c["trials"]) for c in experiment.tracks(mine["id"], "lab-a")["tasks"][0]["conditions"]] == [2]
    assert experiment.tracks(mine["id"]) == experiment.tracks(mine["id"], "lab-a"), "the admin sees every site's"
    with pytest.raises(NotFound):
        experiment.tracks(mine["id"], "lab-b")
    thesis = experiment.create_session(study_id="thesis-2021", participant="P09", experimenter="alice")
    assert experiment.tracks(thesis["id"]) == {"session": thesis["id"], "tasks": []}
    store.close()
