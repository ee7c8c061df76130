"""server/analysis/psychophysics.py on psychophysics records made by the synthetic observer
answering the real procedures (tests/analysis/psychophysics_rows.py): the fits equal statsmodels'
GLM through the analysis's grouping, recover the simulated thresholds, the procedure's estimate
is the last record's, d′ and information transfer come from the right counts, bad records are
left out with a reason, and the same data give the same numbers."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest
import statsmodels.api as sm

from server.analysis import psychophysics as psy
from server.psychophysics import information, sdt
from server.psychophysics.functions import FAMILIES
from server.psychophysics.observer import PsychometricObserver
from tests.analysis import psychophysics_rows as pr

CONSTANT = {"kind": "constant", "levels": [5, 10, 15, 20, 25, 30], "repeats": 20}
STAIRCASE = {"kind": "up-down", "start": 40, "steps": [8, 4, 2], "up": 1, "down": 2, "max_reversals": 12,
             "average": 8, "min": 0.5, "max": 100}
TWO_AFC = PsychometricObserver(15.0, 0.3, 0.5, 0.0, "logistic")
YES_NO = PsychometricObserver(15.0, 0.3, 0.0, 0.0, "logistic")


def analyse(data, **kw):
    rows, unusable = psy.select(pr.trials(data))
    return psy.analyze(rows, unusable, **kw)


def task_of(section, name):
    return next(t for t in section["tasks"] if t["task"] == name)


@pytest.mark.parametrize("family,link", [("logistic", sm.families.links.Logit()),
                                         ("normal", sm.families.links.Probit())])
def test_yes_no_fit_without_lapse_equals_the_binomial_glm(family, link):
    rng = np.random.default_rng(3)
    data = {f"P{i}": {"yn": pr.records("yes-no", YES_NO, CONSTANT, rng, noise_rate=0.0)} for i in range(4)}
    section, _ = analyse(data, samples=50, lapse_max=0.0)
    # the counts, straight from the records
    counts = Counter()
    for recs in data.values():
        for r in recs["yn"]:
            counts[(r["level"], "n")] += 1
            counts[(r["level"], "k")] += r["answer"] == "yes"
    levels = np.array(sorted({lv for lv, _ in counts}))
    n = np.array([counts[(lv, "n")] for lv in levels])
    k = np.array([counts[(lv, "k")] for lv in levels])
    glm = sm.GLM(np.column_stack([k, n - k]), sm.add_constant(levels), family=sm.families.Binomial(link=link)) \
        .fit(tol=1e-14)
    b0, b1 = glm.params
    ours = task_of(section, "yn")["conditions"][0]["families"][family]
    assert ours["slope"] == pytest.approx(b1, abs=1e-6)
    assert ours["threshold"] == pytest.approx(-b0 / b1, abs=1e-6)
    assert ours["deviance"] == pytest.approx(glm.deviance, abs=1e-6)
    assert ours["lapse"] == 0.0
    pooled = task_of(section, "yn")["conditions"][0]["pooled"]
    assert [(p["level"], p["n"], p["k"]) for p in pooled["points"]] == list(zip(levels.tolist(), n.tolist(), k.tolist()))


def level_at(fit: dict, p: float) -> float:
    return float(FAMILIES[fit["family"]].level_at(p, fit["threshold"], fit["slope"], fit["guess"], fit["lapse"]))


def test_constant_stimuli_recover_the_simulated_threshold_per_condition():
    rng = np.random.default_rng(11)
    low = PsychometricObserver(12.0, 0.4, 0.5, 0.0, "logistic")
    many = {**CONSTANT, "repeats": 40}
    data = {f"P{i}": {"detect": pr.records("2ifc", TWO_AFC, many, rng, condition="f250")
                      + pr.records("2ifc", low, many, rng, condition="f100")} for i in range(8)}
    section, skipped = analyse(data)
    assert skipped == {}
    task = task_of(section, "detect")
    assert task["design"] == "2ifc" and task["guess"] == 0.5 and task["n_participants"] == 8
    assert [c["condition"] for c in task["conditions"]] == ["f100", "f250"]
    for cond, truth in zip(task["conditions"], (low, TWO_AFC)):
        pooled = cond["pooled"]
        assert pooled["n_trials"] == 8 * 240 and cond["family"] in psy.FAMILIES
        assert pooled["fit"]["family"] == cond["family"]
        # whatever the family, the fitted curve passes 75 % correct where the observer does (±1.5: some
        # 3 standard errors of 1920 trials)
        assert level_at(pooled["fit"], 0.75) == pytest.approx(truth.level_at(0.75), abs=1.5)
        lo, hi = pooled["bootstrap"]["threshold_ci95"]
        assert lo < pooled["fit"]["threshold"] < hi and hi - lo < 4
        # the midpoint (F = ½) is 75 % correct in 2AFC without lapse, whatever the family
        assert pooled["fit"]["midpoint"] == pytest.approx(level_at({**pooled["fit"], "lapse": 0.0}, 0.75))
        lo, hi = pooled["bootstrap"]["midpoint_ci95"]
        assert lo < pooled["fit"]["midpoint"] < hi
        assert 0 <= pooled["bootstrap"]["deviance_p"] <= 1 and pooled["bootstrap"]["samples"] == psy.BOOTSTRAP_SAMPLES
        assert 0 <= pooled["fit"]["lapse"] <= psy.LAPSE_MAX
        assert len(cond["participants"]) == 8
        for cell in cond["participants"]:
            assert cell["fit"]["family"] == cond["family"]
            assert level_at(cell["fit"], 0.75) == pytest.approx(truth.level_at(0.75), abs=5.0)
        assert pooled["procedure_estimate"] is None  # constant stimuli: the fit estimates


def test_staircase_estimate_is_the_last_record_and_lands_near_its_target():
    rng = np.random.default_rng(5)
    data = {f"P{i}": {"detect": pr.records("2ifc", TWO_AFC, STAIRCASE, rng)} for i in range(8)}
    section, _ = analyse(data, samples=100)
    cond = task_of(section, "detect")["conditions"][0]
    assert cond["condition"] == "main"
    last = {code: recs["detect"][-1]["estimate"] for code, recs in data.items()}
    assert {c["participant"]: c["procedure_estimate"] for c in cond["participants"]} == last
    assert cond["pooled"]["procedure_estimate"] == pytest.approx(np.mean(list(last.values())))
    assert cond["pooled"]["procedure_estimate_n"] == 8
    # 1-up/2-down tracks 70.7 % correct (Levitt 1971)
    assert cond["pooled"]["procedure_estimate"] == pytest.approx(TWO_AFC.level_at(0.7071), abs=2.5)
    assert level_at(cond["pooled"]["fit"], 0.75) == pytest.approx(TWO_AFC.level_at(0.75), abs=2.0)


def test_estimates_of_interleaved_and_quest_plus_records():
    assert psy._estimate_value({"f250": 14.0, "f100": 9.0}, "f100") == 9.0
    assert psy._estimate_value({"threshold": 3.5, "slope": 2.0}, "main") == 3.5
    assert psy._estimate_value({"f250": {"threshold": 2.0}}, "f250") == 2.0
    assert psy._estimate_value(None, "main") is None
    assert psy._estimate_value(float("nan"), "main") is None


@pytest.mark.parametrize("design", ["yes-no", "same-different"])
def test_d_prime_from_signal_and_noise_trials(design):
    rng = np.random.default_rng(8)
    data = {f"P{i}": {"t": pr.records(design, YES_NO, CONSTANT, rng, noise_rate=0.3, false_alarm=0.15)}
            for i in range(3)}
    section, skipped = analyse(data, samples=50)
    assert skipped == {}
    cond = task_of(section, "t")["conditions"][0]
    for cell in [cond["pooled"], *cond["participants"]]:
        recs = [r for code, d in data.items() if cell["participant"] in (None, code) for r in d["t"]]
        positive = "yes" if design == "yes-no" else "different"
        hits = sum(r["signal"] and r["answer"] == positive for r in recs)
        fas = sum(not r["signal"] and r["answer"] == positive for r in recs)
        n_signal = sum(r["signal"] for r in recs)
        expect = (sdt.yes_no if design == "yes-no" else sdt.same_different)(hits, n_signal, fas, len(recs) - n_signal)
        s = cell["sdt"]
        assert (s["hits"], s["signal_trials"], s["false_alarms"], s["noise_trials"]) == \
            (hits, n_signal, fas, len(recs) - n_signal)
        assert s["d_prime"] == pytest.approx(expect.d_prime) and s["criterion"] == pytest.approx(expect.criterion)
        assert s["model"] == ("yes-no" if design == "yes-no" else "differencing")
        # the fit uses the signal trials only
        assert sum(p["n"] for p in cell["points"]) == n_signal
    assert cond["pooled"]["sdt"]["d_prime"] > 1


def test_yes_no_without_catch_trials_skips_d_prime_with_a_reason():
    rng = np.random.default_rng(2)
    section, skipped = analyse({"P1": {"yn": pr.records("yes-no", YES_NO, CONSTANT, rng, noise_rate=0.0)}}, samples=20)
    assert task_of(section, "yn")["conditions"][0]["pooled"]["sdt"] is None
    assert "catch" in skipped["psychophysics.yn.main.pooled.sdt"]


def test_information_transfer_of_the_identification_confusion_matrix():
    rng = np.random.default_rng(4)
    data = {f"P{i}": {"ident": pr.identification([100, 200, 300, 400], 0.7, 10, rng)} for i in range(4)}
    data["P9"] = {"ident": pr.identification([100, 200, 300, 400], 1.0, 5, rng)}
    section, skipped = analyse(data)
    assert skipped == {}
    cond = task_of(section, "ident")["conditions"][0]
    matrix = np.zeros((4, 4), dtype=int)
    for d in data.values():
        for r in d["ident"]:
            matrix[r["stimulus_index"], r["answer_index"]] += 1
    info = cond["pooled"]["information"]
    expect = information.information_transfer(matrix)
    assert info["confusion"] == matrix.tolist() and info["labels"] == ["100", "200", "300", "400"]
    assert info["bits"] == pytest.approx(expect.bits) and info["corrected"] == pytest.approx(expect.corrected)
    assert info["correction"] < 0 and info["maximum"] == 2.0 and info["correction_method"] == "Miller-Madow"
    perfect = next(c for c in cond["participants"] if c["participant"] == "P9")["information"]
    assert perfect["bits"] == pytest.approx(math.log2(4)) and perfect["accuracy"] == 1.0
    assert cond["pooled"]["fit"] is None and cond["family"] is None


def test_unusable_records_are_left_out_with_a_reason_and_the_rest_analysed():
    rng = np.random.default_rng(6)
    data = {"P1": {"detect": pr.records("2ifc", TWO_AFC, CONSTANT, rng)}}
    frame = pr.trials(data)
    frame.at[0, "metrics"] = {"psy": {"design": "2ifc", "level": "loud", "choices": ["1", "2"], "correct": True}}
    frame.at[1, "metrics"] = {"psy": {"design": "3ifc", "level": 3.0, "choices": ["1", "2"], "correct": True}}
    frame.at[2, "metrics"] = {"psy": "garbage"}
    frame.at[3, "status"] = "excluded"
    frame.at[4, "kind"] = "practice"
    rows, unusable = psy.select(frame)
    assert unusable == {"detect": 3} and len(rows) == 120 - 5
    section, skipped = psy.analyze(rows, unusable, samples=20)
    assert "3 answered trial(s)" in skipped["psychophysics.detect.unusable"]
    assert task_of(section, "detect")["n_trials"] == 115


def test_too_few_levels_skip_the_fit_with_a_reason():
    rng = np.random.default_rng(7)
    one = {"kind": "constant", "levels": [10], "repeats": 10}
    section, skipped = analyse({"P1": {"d": pr.records("2ifc", TWO_AFC, one, rng)}}, samples=20)
    assert task_of(section, "d")["conditions"][0]["pooled"]["fit"] is None
    assert "2 or more distinct levels, got 1" in skipped["psychophysics.d.main.pooled.fit"]


def test_same_data_same_numbers_and_no_tasks_is_an_empty_section():
    def once():
        rng = np.random.default_rng(9)
        return analyse({f"P{i}": {"detect": pr.records("2ifc", TWO_AFC, STAIRCASE, rng)} for i in range(3)},
                       samples=60)

    assert once() == once()
    section, skipped = psy.analyze(*psy.select(pr.trials({})))
    assert section["tasks"] == [] and section["n_trials"] == 0 and skipped == {}


def test_every_psychophysics_key_is_in_docs_psychophysics():
    from pathlib import Path

    from server.analysis.keys import KEYS

    doc = (Path(__file__).resolve().parents[2] / "docs" / "psychophysics.md").read_text(encoding="utf-8")
    section = doc.split("## stats.json keys", 1)[1]
    assert [k for k in KEYS if k.startswith("psychophysics") and f"`{k}`" not in section] == []


def test_no_bootstrap_when_none_is_asked():
    rng = np.random.default_rng(12)
    section, skipped = analyse({"P1": {"d": pr.records("2ifc", TWO_AFC, CONSTANT, rng)}}, samples=0)
    pooled = task_of(section, "d")["conditions"][0]["pooled"]
    assert pooled["fit"]["threshold"] is not None and pooled["bootstrap"] is None
    assert skipped["psychophysics.d.main.pooled.bootstrap"] == "no bootstrap asked (0 samples)"


def test_a_guess_rate_no_fit_can_take_is_named():
    rng = np.random.default_rng(13)
    recs = pr.records("2ifc", TWO_AFC, CONSTANT, rng)
    for r in recs:
        r["guess"] = 1.5
    section, skipped = analyse({"P1": {"d": recs}}, samples=10)
    assert task_of(section, "d")["conditions"][0]["pooled"]["fit"] is None
    assert "guess rate 1.5" in skipped["psychophysics.d.main.pooled.fit"]
