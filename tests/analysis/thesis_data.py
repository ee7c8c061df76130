"""A database of synthetic sessions of studies/thesis-2021.toml, written with the Store exactly as
the engine would (the real plan, trials through their lifecycle, responses, metrics, events and
samples), with answers drawn by numpy from known models so the analysis must recover them.

Models (parameters in `Truth`): angle answers = angle + N(0, 4 + 0.12·|angle|); pair ratings =
4 + 2.5·log2(250/f2) + noise, rounded to the scale; identification = the choice nearest to
f·exp(N(0, confusion)); estimation / production = round(a·S^b·exp(N(0, 0.05))) on 1..10;
positioning metrics log-normal around the thesis's means, end points jittered at the target.
Practice trials get deliberately wrong answers: an analysis that counted them would show it.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np

from server.experiment.plan import plan_session
from server.experiment.store import Store
from server.experiment.study import load_study

ROOT = Path(__file__).resolve().parents[2]
STUDY = ROOT / "studies" / "thesis-2021.toml"
CHOICES_HZ = (500.0, 333.33, 250.0, 200.0, 166.67)
T0 = datetime(2026, 11, 21, 8, 0, 0, tzinfo=timezone.utc)


@dataclass(frozen=True)
class Truth:
    participants: int = 13
    seed: int = 7
    estimation: tuple[float, float] = (1.164, 0.85)
    production: tuple[float, float] = (0.897, 1.04)
    confusion: float = 0.12          # SD of the log-frequency error of the identifier (0: noiseless)
    level_noise: float = 0.05
    positioning_means: tuple = (("fingertac", 4.4, 14.0), ("ferrovibe", 6.5, 20.0))  # length, time
    outlier: bool = True             # one absurd FingerTac trial (P03, P3, cube_b) the outlier rule must catch
    samples: bool = True             # record end points (samples and pick/go events) for the throughput
    exclude: bool = True             # the experimenter excludes P02's first contact-angle main trial


def clock():
    seconds = itertools.count()
    return lambda: (T0 + timedelta(seconds=next(seconds))).isoformat(timespec="microseconds")


def target_of(obj: str) -> tuple[np.ndarray, np.ndarray]:
    from server.analysis.fitts import item_geometry

    return item_geometry()[obj]


def build(path: Path, truth: Truth = Truth()) -> dict:
    """Write the sessions; returns what was generated (for independent expected values)."""
    study = load_study(STUDY)
    text = STUDY.read_text(encoding="utf-8")
    rng = np.random.default_rng(truth.seed)
    store = Store(path, clock())
    drawn: dict[str, list] = {"estimation": [], "production": [], "ident": [], "angles": [], "pairs": [],
                              "positioning": [], "excluded": []}
    try:
        for p in range(truth.participants):
            code = f"P{p + 1:02d}"
            sid = f"s{p + 1:011d}"
            plan = [item.to_dict() for item in plan_session(study, p)]
            store.create_session(session_id=sid, study_id=study.id, study_title=study.title,
                                 study_hash=study.source_hash, study_text=text, participant=code,
                                 participant_index=p, device=None, experimenter="test", notes="",
                                 software_version="0.1.0", config={"tick_hz": 1000, "record_every": 10}, plan=plan)
            tick = 0
            for trial in store.trials(sid):
                tick += 100_000
                _run(store, sid, code, trial, tick, rng, truth, drawn)
            store.set_session_status(sid, "completed")
    finally:
        store.close()
    return drawn


def _run(store, sid, code, t, tick, rng, truth: Truth, drawn) -> None:
    store.transition(t.id, "running", tick=tick)
    answers, metrics = {}, {}
    p = t.params
    main = t.kind == "main"
    if t.task == "contact_angle" and t.kind in ("trial", "main"):
        angle = p["angle_deg"]
        answer = float(np.clip(round(angle + rng.normal(0, 4 + 0.12 * abs(angle))), -90, 90)) if main else -angle
        answers["answer_deg"] = answer
        if main:
            drawn["angles"].append((code, angle, answer))
    elif t.task == "texture_pairs" and main:
        f2 = 1e6 / p["second_period_us"]
        answers["rating"] = int(np.clip(round(4 + 2.5 * np.log2(250 / f2) + rng.normal(0, 0.6)), 1, 7))
        drawn["pairs"].append((code, round(f2, 2), answers["rating"]))
    elif t.task == "texture_identification" and t.kind in ("trial", "main"):
        f = 1e6 / p["period_us"]
        seen = f * np.exp(rng.normal(0, truth.confusion)) if truth.confusion else f
        answers["answer_hz"] = min(CHOICES_HZ, key=lambda c: abs(np.log(c / seen))) if main else 500.0
        if main:
            drawn["ident"].append((code, round(f, 2), answers["answer_hz"]))
    elif t.task.startswith("stiffness") and main:
        mode, level = p["mode"], p["level"]
        a, b = truth.estimation if mode == "estimation" else truth.production
        value = int(np.clip(round(a * level ** b * np.exp(rng.normal(0, truth.level_noise))), 1, 10))
        drawn[mode].append((code, level, value))
        if mode == "estimation":
            answers["answer_level"] = value
        else:
            metrics = {"produced_level": value, "target_level": level, "match_time_s": round(5 + rng.gamma(2, 2), 3)}
    elif t.scenario == "positioning-v1" and t.kind in ("trial", "main"):
        metrics = _positioning(store, sid, code, t, tick, rng, truth)
        if "helpfulness" in t.questions:
            answers["helpfulness"] = int(np.clip(round(rng.normal(5.3, 1.0)), 1, 7))
        if main:
            drawn["positioning"].append((code, t.device, p["cue"], p["object"], metrics["path_length"],
                                         metrics["completion_s"], answers.get("helpfulness")))
    elif t.kind == "questionnaire":
        answers.update({"better_mode": "continuous vibration at target" if rng.random() < 0.85
                        else "no vibration at target", "better_by": int(np.clip(round(rng.normal(6, 0.7)), 1, 7)),
                        "best_pattern": ["P1", "P2", "P3", "all felt the same"][int(rng.integers(0, 4))]})
        answers = {q: answers[q] for q in t.questions}
    for question, value in answers.items():
        store.put_response(t.id, question, value, "experimenter")
    store.transition(t.id, "answered", tick=tick + 30_000, metrics=metrics)
    if truth.exclude and code == "P02" and t.task == "contact_angle" and main and t.index == 0:
        store.transition(t.id, "excluded", reason="participant sneezed")
        drawn["excluded"].append((code, p["angle_deg"]))
        drawn["angles"].pop()


def _positioning(store, sid, code, t, tick, rng, truth: Truth) -> dict:
    device = t.device
    length_mean, time_mean = dict((d, (m1, m2)) for d, m1, m2 in truth.positioning_means)[device]
    length = float(length_mean * np.exp(rng.normal(0, 0.3)))
    time = float(time_mean * np.exp(rng.normal(0, 0.3)))
    if truth.outlier and code == "P03" and t.params.get("cue") == "P3" and t.params["object"] == "cube_b":
        length, time = 60.0, 200.0
    end_error = float(abs(rng.normal(0.02, 0.008)))
    if truth.samples and t.kind == "main":
        start, target = target_of(t.params["object"])
        pick, go = tick + 500, tick + 500 + int(time * 1000) - 3000
        store.add_events([(sid, t.id, t.attempt + 1, pick, "scenario", {"name": "pick", "tick": pick}),
                          (sid, t.id, t.attempt + 1, go, "scenario", {"name": "go", "tick": go})])
        end = target + rng.uniform(-0.03, 0.03, 3)
        rows = [(k, *end, *end, 0, t.params["object"], *(end + rng.normal(0, 0.001, 3)))
                for k in range(go - 2000, go + 1, 10)]
        store.add_samples(t.id, t.attempt + 1, rows)
    return {"completion_s": round(time, 6), "time_to_target_s": round(time * 0.6, 6), "path_length": round(length, 9),
            "hold_error_mean": round(end_error, 9), "hold_depth_error_mean": round(end_error * 0.5, 9)}
