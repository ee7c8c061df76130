"""Psychophysics trial records (metrics["psy"], the study part's record of a finished trial) made
without the engine: the existing synthetic observer (server/psychophysics/observer.py) answers the
existing procedures (server/psychophysics/procedures.py), and each answer becomes the record a
finished trial carries. `trials()` gives them as rows of the loaded-trials frame (load.py), so
the analysis runs on them as on a database.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from server.analysis.load import TRIAL_COLUMNS
from server.psychophysics.observer import PsychometricObserver
from server.psychophysics.procedures import parse_procedure, start

CHOICES = {"yes-no": ["yes", "no"], "same-different": ["same", "different"], "2ifc": ["1", "2"]}


def records(design: str, observer: PsychometricObserver, procedure: dict, rng: np.random.Generator,
            noise_rate: float = 0.25, false_alarm: float = 0.1, choices: list[str] | None = None,
            condition: str | None = None, parameter: str = "intensity_pct", unit: str = "%") -> list[dict]:
    """One participant's records of one procedure, answered by `observer` (yes-no and
    same-different: a share `noise_rate` of catch / same trials, answered "yes" / "different"
    with probability `false_alarm`; they do not move the procedure)."""
    spec = parse_procedure(procedure)
    proc = start(spec, int(rng.integers(0, 2**31)))
    choices = choices or CHOICES.get(design) or [str(i + 1) for i in range(int(round(1 / observer.guess)))]
    out = []
    trial = 0
    while not proc.finished:
        level = float(proc.level)
        psy = {"design": design, "condition": condition, "parameter": parameter, "unit": unit, "level": level,
               "reference": None, "target": None, "signal": None, "stimulus_index": None, "choices": choices,
               "guess": observer.guess, "trial": trial}
        if design in ("yes-no", "same-different"):
            signal = bool(rng.random() >= noise_rate)
            positive = bool(observer.answer(level, rng)) if signal else bool(rng.random() < false_alarm)
            correct = positive if signal else not positive
            answer_index = (0 if positive else 1) if design == "yes-no" else (1 if positive else 0)
            psy.update(signal=signal, reference=0.0 if design == "same-different" else None)
        else:
            n = len(choices)
            target = int(rng.integers(0, n))
            correct = bool(observer.answer(level, rng))
            answer_index = target if correct else int((target + 1 + rng.integers(0, n - 1)) % n)
            psy.update(target=target + 1, reference=0.0)
            signal = True
        before = len(getattr(proc, "reversals", ()))
        if signal:
            proc.update(correct)
        psy.update(answer=choices[answer_index], answer_index=answer_index, correct=correct,
                   reversal=len(getattr(proc, "reversals", ())) > before, procedure=proc.record(),
                   estimate=proc.estimate())
        out.append(psy)
        trial += 1
    return out


def identification(levels: list[float], p_correct: float, repeats: int, rng: np.random.Generator) -> list[dict]:
    """Absolute identification of k stimuli: right with probability p_correct, else one of the
    other answers at random."""
    k = len(levels)
    labels = [f"{x:g}" for x in levels]
    order = rng.permutation(np.repeat(np.arange(k), repeats))
    out = []
    for trial, s in enumerate(order):
        s = int(s)
        a = s if rng.random() < p_correct else int((s + 1 + rng.integers(0, k - 1)) % k)
        out.append({"design": "identification", "condition": None, "parameter": "carrier_hz", "unit": "Hz",
                    "level": float(levels[s]), "reference": None, "target": None, "signal": None,
                    "stimulus_index": s, "choices": labels, "answer": labels[a], "answer_index": a,
                    "correct": a == s, "guess": 1 / k, "trial": trial, "reversal": False,
                    "procedure": {"trial": trial + 1}, "estimate": None})
    return out


def trials(per_participant: dict[str, dict[str, list[dict]]]) -> pd.DataFrame:
    """participant → task → records, as answered main trials of the loaded-trials frame."""
    rows = []
    for p, (code, tasks) in enumerate(per_participant.items()):
        seq = 0
        for task, recs in tasks.items():
            for psy in recs:
                rows.append({"trial_id": len(rows) + 1, "session": f"s{p:03d}", "participant": code, "seq": seq,
                             "task": task, "kind": "main", "index": seq, "condition": psy.get("condition"),
                             "repetition": 0, "status": "answered", "attempt": 1, "reason": None,
                             "scenario": "stimulus-v1", "scenario_base": "stimulus", "device": "audio",
                             "params": {}, "scenario_params": {}, "responses": {"response": psy["answer"]},
                             "metrics": {"psy": psy}, "tick_hz": 1000})
                seq += 1
    return pd.DataFrame(rows, columns=TRIAL_COLUMNS)


def write_database(path, per_participant: dict[str, dict[str, list[dict]]], study_id: str = "psy-test") -> None:
    """The same records as finished trials of sessions written with the Store (one session per
    participant, a `response` question each), as the engine leaves them."""
    from tests.analysis.thesis_data import clock
    from server.experiment.store import Store

    store = Store(path, clock())
    try:
        for p, (code, tasks) in enumerate(per_participant.items()):
            plan, records = [], []
            for task, recs in tasks.items():
                for psy in recs:
                    plan.append({"seq": len(plan), "task": task, "kind": "main", "index": len(plan),
                                 "scenario": "stimulus-v1", "scenario_params": {}, "device": None,
                                 "params": {"parameter": psy["parameter"], "level_1": psy["level"]},
                                 "condition": psy.get("condition"), "repetition": 0, "duration_s": None,
                                 "questions": ["response"]})
                    records.append(psy)
            sid = f"s{p + 1:011d}"
            store.create_session(session_id=sid, study_id=study_id, study_title="Psychophysics test",
                                 study_hash="0" * 64, study_text="", participant=code, participant_index=p,
                                 device="audio", experimenter="test", notes="", software_version="0.1.0",
                                 config={"tick_hz": 1000}, plan=plan)
            for trial, psy in zip(store.trials(sid), records):
                store.transition(trial.id, "running", tick=trial.seq * 1000)
                store.put_response(trial.id, "response", psy["answer"], "participant")
                store.transition(trial.id, "answered", tick=trial.seq * 1000 + 500, metrics={"psy": psy})
            store.set_session_status(sid, "completed")
    finally:
        store.close()
