"""Recorded sessions → pandas frames, read through `server.experiment.export.Reader`.

The Reader opens the database read-only and reads it in one transaction, so the analysis may run
while a server records (docs/data.md). Nothing here writes SQL of its own: sessions, trials and
responses come from the Reader's queries, and so do the events and samples that the throughput
needs (positioning trials only).

`trials` has one row per planned trial of every chosen session, whatever its status; the task
modules keep the `answered` ones. Dict columns (`params`, `scenario_params`, `responses`,
`metrics`) hold the decoded JSON. `device` is the task's device, else the session's.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from server.experiment.export import DB_NAME, ExportError, Reader, session_tick_hz, known_sessions

TRIAL_COLUMNS = ("trial_id", "session", "participant", "seq", "task", "kind", "index", "condition", "repetition",
                 "status", "attempt", "reason", "scenario", "scenario_base", "device", "params", "scenario_params",
                 "responses", "metrics", "tick_hz")
ENDPOINT_COLUMNS = ("trial_id", "pick_tick", "go_tick", "hold_s", "end_x", "end_y", "end_z", "n_samples")
SESSION_COLUMNS = ("session", "study_id", "study_title", "study_hash", "participant", "participant_index",
                   "device", "status", "created_utc", "software_version", "tick_hz")


class AnalysisError(Exception):
    """Data that cannot be analysed as asked (the CLI exits 2 with the message)."""


@dataclass
class Dataset:
    sessions: pd.DataFrame
    trials: pd.DataFrame
    endpoints: pd.DataFrame   # positioning trials: the held object's mean position over the hold before GO
    db_path: Path


def database_file(data: str | Path) -> Path:
    """DATA is a data directory (`serve --data-dir`) or the .sqlite file itself."""
    path = Path(data)
    return path / DB_NAME if path.is_dir() else path


def scenario_base(scenario: str) -> str:
    """`positioning-v1` → `positioning`: analyses know a scenario by name, whatever its version."""
    name, sep, version = scenario.rpartition("-v")
    return name if sep and version.isdigit() else scenario


def load(data: str | Path, study: str | None = None) -> Dataset:
    """Every session of one study. Without `study` the database must hold exactly one."""
    path = database_file(data)
    try:
        with Reader(path) as reader:
            sessions = _choose(reader.sessions(), study, path)
            trial_rows, endpoint_rows = [], []
            for s in sessions:
                tick_hz = session_tick_hz(s.get("config") or {})
                rows = _trials(reader, s, tick_hz)
                trial_rows += rows
                endpoint_rows += _endpoints(reader, s["id"], rows, tick_hz)
    except ExportError as exc:
        raise AnalysisError(str(exc)) from None
    frame = pd.DataFrame([{**{k: s[k] for k in SESSION_COLUMNS[1:-1]}, "session": s["id"],
                           "tick_hz": session_tick_hz(s.get("config") or {})} for s in sessions], columns=SESSION_COLUMNS)
    return Dataset(frame, pd.DataFrame(trial_rows, columns=TRIAL_COLUMNS),
                   pd.DataFrame(endpoint_rows, columns=ENDPOINT_COLUMNS), path)


def _choose(sessions: list[dict], study: str | None, path: Path) -> list[dict]:
    studies = sorted({s["study_id"] for s in sessions})
    if not sessions:
        raise AnalysisError(f"{path}: {known_sessions(sessions)}")
    if study is None:
        if len(studies) > 1:
            raise AnalysisError(f"{path} holds sessions of several studies ({', '.join(studies)}); "
                                f"choose one with --study")
        return sessions
    chosen = [s for s in sessions if s["study_id"] == study]
    if not chosen:
        raise AnalysisError(f"{path} has no sessions of study {study!r} (studies: {', '.join(studies)})")
    return chosen


def _trials(reader: Reader, session: dict, tick_hz: float) -> list[dict]:
    responses: dict[int, dict] = {}
    for r in reader.responses(session["id"]):
        responses.setdefault(r["trial_id"], {})[r["question"]] = r["value"]
    return [{"trial_id": t["id"], "session": session["id"], "participant": session["participant"], "seq": t["seq"],
             "task": t["task"], "kind": t["kind"], "index": t["index"], "condition": t["condition"],
             "repetition": t["repetition"], "status": t["status"], "attempt": t["attempt"], "reason": t["reason"],
             "scenario": t["scenario"], "scenario_base": scenario_base(t["scenario"]),
             "device": (t["device"] or session["device"] or "").lower() or None, "params": t["params"] or {},
             "scenario_params": t["scenario_params"] or {}, "responses": responses.get(t["id"], {}),
             "metrics": t["metrics"] or {}, "tick_hz": tick_hz}
            for t in reader.trials(session["id"])]


def _endpoints(reader: Reader, session_id: str, trials: list[dict], tick_hz: float) -> list[dict]:
    """Per answered positioning main trial: the pick and GO ticks of its latest attempt and the
    held object's mean position over the hold that led to GO (the ISO 9241-411 end point)."""
    wanted = {t["trial_id"]: t for t in trials if t["scenario_base"] == "positioning" and t["kind"] == "main"
              and t["status"] == "answered"}
    if not wanted:
        return []
    ticks: dict[int, dict] = {}
    for e in reader.events(session_id):
        t = wanted.get(e["trial_id"])
        if t is None or e["kind"] != "scenario" or e["attempt"] != t["attempt"] or e["tick"] is None:
            continue
        name = (e["body"] or {}).get("name")
        if name == "pick":
            ticks.setdefault(t["trial_id"], {}).setdefault("pick", e["tick"])  # the first pick
        elif name == "go":
            ticks.setdefault(t["trial_id"], {})["go"] = e["tick"]               # the last GO
    out = []
    for trial_id, tk in sorted(ticks.items()):
        if "go" not in tk:
            continue
        t = wanted[trial_id]
        hold_s = float(t["scenario_params"].get("hold_s", 2.0))
        start = tk["go"] - round(hold_s * tick_hz)
        held = [r for r in reader.samples(trial_id, t["attempt"])
                if start <= r["tick"] <= tk["go"] and r["held"] is not None and r["held_x"] is not None]
        if not held:
            continue
        n = len(held)
        out.append({"trial_id": trial_id, "pick_tick": tk.get("pick"), "go_tick": tk["go"], "hold_s": hold_s,
                    "end_x": sum(r["held_x"] for r in held) / n, "end_y": sum(r["held_y"] for r in held) / n,
                    "end_z": sum(r["held_z"] for r in held) / n, "n_samples": n})
    return out


def answered(trials: pd.DataFrame, scenario: str, kinds: tuple[str, ...] = ("main",)) -> pd.DataFrame:
    """The answered trials of a scenario (by name, any version) and kinds; excluded, aborted and
    pending trials never count."""
    if trials.empty:
        return trials
    keep = (trials["scenario_base"] == scenario) & trials["kind"].isin(kinds) & (trials["status"] == "answered")
    return trials[keep]


def number(value) -> float | None:
    """A numeric answer or metric as float (numeric strings too), else None."""
    if isinstance(value, bool) or value is None:
        return None
    try:
        return float(value)
    except (TypeError, ValueError):
        return None
