"""`viestac export`: experiment sessions out of SQLite into CSV and JSON files (docs/data.md).

Per session, into OUT/<study_id>_<participant>_<session_id>/:
  trials_wide.csv      one row per trial, like PsychoPy's wide text (session columns first, then
                       the trial's own, then `param.*`, `scenario.*`, `response.*`, `metric.*`)
  responses_long.csv   one row per response
  trajectories/trial_<seq>_attempt_<n>.csv   the recorded samples of each attempt that has some
  trajectories/trial_<seq>_attempt_<n>_points.csv   with several tracked points (fingers, a hand):
                       every point of those samples, in the multi-point CSV `viestac render` reads
  cues.csv, events.csv the cue commands and the events
  audit.csv            the control actions on the session (who, what, when, the result), when the
                       data directory has an access log (access.sqlite, server/auth/)
  session.json         the whole session (row, config, study text, trials with responses and
                       metrics, attempts, events): a re-analysis needs nothing else
`--all` also writes OUT/all_trials_wide.csv, the wide rows of every session; `--site` keeps only
one lab's sessions (each lab gets its own data).

Reading never changes the database: it is opened read-only (`mode=ro`) and read in one
transaction, a consistent snapshot even while a server records into it (WAL readers do not block
the writer). The Store is not used, because opening it runs the crash recovery (it resets a
`running` trial), which must only happen when a server starts.

Writing is all or nothing per run: every file is first written into a staging directory inside
OUT, then compared with what OUT already holds. Identical files are left alone (re-running an
export of unchanged data is a no-op); a file that differs, or a file of an earlier export that
this one would not write, is a different export and is refused unless `force`. Files then move
into place one by one with os.replace (atomic), and the staging directory is removed.
"""

from __future__ import annotations

import csv
import filecmp
import json
import math
import os
import re
import shutil
import sqlite3
import tempfile
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any, Iterable, Iterator

from server import __version__
from server.core.numbers import is_number
from server.core.points import POINT_NAMES
from server.core.records import multipoint_columns
from server.experiment.store import SAMPLE_COLUMNS, SCHEMA_VERSION

DB_NAME = "viestac.sqlite"
FORMAT = "viestac-session-export"
FORMAT_VERSION = 1
DEFAULT_TICK_HZ = 1000.0

SESSION_COLUMNS = ("session", "study", "participant", "participant_index", "device", "experimenter",
                   "software_version")
TRIAL_COLUMNS = ("seq", "task", "kind", "index", "condition", "repetition", "status", "attempt", "started_utc",
                 "ended_utc", "started_tick", "ended_tick", "duration_s", "duration_from", "reason", "scenario",
                 "trial_device", "planned_duration_s", "device_off", "trajectory")
WIDE_COLUMNS = SESSION_COLUMNS + TRIAL_COLUMNS
WIDE_GROUPS = ("param", "scenario", "response", "metric")  # then one column per name, sorted, per group
LONG_COLUMNS = ("session", "study", "participant", "participant_index", "seq", "task", "kind", "index", "condition",
                "repetition", "trial_status", "question", "value", "value_json", "entered_by", "answered_utc")
TRAJECTORY_HEADER = ("tick", "t_s") + tuple(c for c in SAMPLE_COLUMNS if c != "tick")
CUE_COLUMNS = ("seq", "attempt", "tick", "cues")
AUDIT_COLUMNS = ("id", "utc", "token_id", "role", "site", "action", "target", "result", "detail")
ACCESS_DB_NAME = "access.sqlite"  # server/auth: the audit log lives beside the experiment database
MAX_AUDIT_ROWS = 1_000_000
EVENT_COLUMNS = ("seq", "attempt", "tick", "utc", "kind", "body")
TRIAL_KEYS = ("id", "session_id", "seq", "task", "kind", "index", "condition", "repetition", "scenario",
              "scenario_params", "device", "params", "planned_duration_s", "questions", "status", "attempt",
              "started_utc", "ended_utc", "started_tick", "ended_tick", "reason", "metrics")
SESSION_FILES = ("trials_wide.csv", "responses_long.csv", "cues.csv", "events.csv", "session.json", "audit.csv")
ALL_WIDE = "all_trials_wide.csv"
_TRAJECTORY_FILE = re.compile(r"trial_\d+_attempt_\d+(_points)?\.csv\Z")
_UNSAFE = re.compile(r"[^A-Za-z0-9_.-]")


class ExportError(Exception):
    """An export that cannot be done as asked; the message says why (the CLI exits 2)."""


def database_path(data_dir: str | Path) -> Path:
    """Where `viestac serve --data-dir DATA_DIR` keeps its database."""
    return Path(data_dir) / DB_NAME


# -- values -------------------------------------------------------------------------------------
def _json(value: Any) -> str:
    return json.dumps(_finite(value), sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False)


def _finite(value: Any) -> Any:
    """JSON has no NaN or infinity: they become null (docs/data.md)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def cell(value: Any) -> str:
    """A CSV cell: empty for None, true/false, numbers as Python writes them (shortest round-trip
    form), text as is, lists and objects as compact JSON."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return value
    return _json(value)


def _utc(text: str | None) -> datetime | None:
    try:
        return datetime.fromisoformat(text) if text else None
    except ValueError:
        return None


def _duration(trial: dict, tick_hz: float) -> tuple[float | None, str]:
    """Seconds the trial's last attempt ran: from its ticks when both are known, else from the
    server's UTC stamps, else unknown. Never negative: ticks that went back (a loop restart in a
    trial, before restarted loops continued the tick count) fall back to UTC, a clock stepped back
    to unknown."""
    start, end = trial.get("started_tick"), trial.get("ended_tick")
    if start is not None and end is not None and end >= start:
        return round((end - start) / tick_hz, 9), "ticks"
    t0, t1 = _utc(trial.get("started_utc")), _utc(trial.get("ended_utc"))
    if t0 is not None and t1 is not None and (t0.tzinfo is None) == (t1.tzinfo is None) and t1 >= t0:
        return round((t1 - t0).total_seconds(), 6), "utc"
    return None, ""


def session_tick_hz(config: dict) -> float:
    hz = config.get("tick_hz") if isinstance(config, dict) else None
    return float(hz) if is_number(hz) and hz > 0 else DEFAULT_TICK_HZ


def _safe(text: Any) -> str:
    return _UNSAFE.sub("-", str(text)) or "-"


def folder_name(session: dict) -> str:
    """The session's export folder: <study_id>_<participant>_<session_id> (unsafe characters → '-')."""
    return f"{_safe(session['study_id'])}_{_safe(session['participant'])}_{_safe(session['id'])}"


def trajectory_name(seq: int, attempt: int) -> str:
    return f"trajectories/trial_{seq}_attempt_{attempt}.csv"


# -- reading (read-only, one snapshot) ------------------------------------------------------------
def _decode(row: sqlite3.Row) -> dict:
    """A row as a dict; `x_json` columns decoded into `x`."""
    out = {}
    for key in row.keys():
        if key.endswith("_json"):
            out[key[:-5]] = json.loads(row[key]) if row[key] is not None else None
        else:
            out[key] = row[key]
    return out


class Reader:
    """The database opened read-only; every query runs in one read transaction (a snapshot)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        if not self.path.is_file():
            raise ExportError(f"no database at {self.path} (the data directory of `viestac serve --data-dir`; "
                              f"default $VIESTAC_DATA or ./data)")
        self.db = None
        try:
            self.db = sqlite3.connect(self.path.resolve().as_uri() + "?mode=ro", uri=True, isolation_level=None)
            self.db.row_factory = sqlite3.Row
            self.db.execute("BEGIN")
            meta = dict(self.db.execute("SELECT key, value FROM meta").fetchall())
        except sqlite3.Error as exc:
            if self.db is not None:
                self.db.close()
            raise ExportError(f"cannot read {self.path} as a ViESTac database: {exc}") from None
        version = meta.get("schema_version")
        if version != str(SCHEMA_VERSION):
            self.db.close()
            raise ExportError(f"{self.path} has schema version {version}; this export reads version {SCHEMA_VERSION}")

    def close(self) -> None:
        self.db.execute("ROLLBACK")  # nothing was written; this ends the snapshot
        self.db.close()

    def __enter__(self) -> "Reader":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def sessions(self) -> list[dict]:
        return [_decode(r) for r in self.db.execute("SELECT * FROM sessions ORDER BY created_utc, id")]

    def trials(self, session_id: str) -> list[dict]:
        """The trials in seq order; `idx` → `index`, the plan's `duration_s` → `planned_duration_s`."""
        out = []
        for r in self.db.execute("SELECT * FROM trials WHERE session_id = ? ORDER BY seq", (session_id,)):
            t = _decode(r)
            t["index"], t["planned_duration_s"] = t.pop("idx"), t.pop("duration_s")
            out.append({**{k: t.pop(k) for k in TRIAL_KEYS if k in t}, **t})  # the plan's order, then the rest
        return out

    def responses(self, session_id: str) -> list[dict]:
        return [_decode(r) for r in self.db.execute(
            "SELECT r.*, t.seq FROM responses r JOIN trials t ON t.id = r.trial_id WHERE t.session_id = ? "
            "ORDER BY t.seq, r.question", (session_id,))]

    def events(self, session_id: str) -> list[dict]:
        return [_decode(r) for r in self.db.execute(
            "SELECT e.*, t.seq FROM events e LEFT JOIN trials t ON t.id = e.trial_id WHERE e.session_id = ? "
            "ORDER BY e.id", (session_id,))]

    def cues(self, session_id: str) -> list[dict]:
        return [_decode(r) for r in self.db.execute(
            "SELECT t.seq, c.attempt, c.tick, c.cues_json FROM cues c JOIN trials t ON t.id = c.trial_id "
            "WHERE t.session_id = ? ORDER BY t.seq, c.attempt, c.tick", (session_id,))]

    def attempts(self, session_id: str) -> dict[tuple[int, int], dict]:
        """(trial id, attempt) → counts and tick range of its samples and cues."""
        out: dict[tuple[int, int], dict] = {}
        for table in ("samples", "cues"):
            for r in self.db.execute(
                    f"SELECT x.trial_id, x.attempt, COUNT(*) AS n, MIN(x.tick) AS first, MAX(x.tick) AS last "
                    f"FROM {table} x JOIN trials t ON t.id = x.trial_id WHERE t.session_id = ? "
                    f"GROUP BY x.trial_id, x.attempt", (session_id,)):
                a = out.setdefault((r["trial_id"], r["attempt"]), {"attempt": r["attempt"], "samples": 0,
                                                                  "first_tick": None, "last_tick": None, "cues": 0})
                if table == "samples":
                    a.update(samples=r["n"], first_tick=r["first"], last_tick=r["last"])
                else:
                    a["cues"] = r["n"]
        return out

    def point_samples(self, trial_id: int, attempt: int) -> list[tuple[int, dict]]:
        """[tick, {point: [x, y, z]}] of an attempt with several tracked points (none in a database
        made before they were recorded)."""
        if not self.db.execute("SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'point_samples'").fetchone():
            return []
        return [(r["tick"], json.loads(r["points_json"])) for r in self.db.execute(
            "SELECT tick, points_json FROM point_samples WHERE trial_id = ? AND attempt = ? ORDER BY tick",
            (trial_id, attempt))]

    def samples(self, trial_id: int, attempt: int) -> Iterator[sqlite3.Row]:
        return self.db.execute(f"SELECT {', '.join(SAMPLE_COLUMNS)} FROM samples WHERE trial_id = ? AND attempt = ? "
                               f"ORDER BY tick", (trial_id, attempt))


def known_sessions(sessions: list[dict]) -> str:
    if not sessions:
        return "the database has no sessions"
    return "known sessions: " + "; ".join(
        f"{s['id']} ({s['study_id']}, participant {s['participant']}, {s['status']})" for s in sessions)


# -- one session in memory (without its samples) ------------------------------------------------
@dataclass
class SessionData:
    session: dict
    trials: list[dict]
    responses: list[dict]
    events: list[dict]
    cues: list[dict]
    tick_hz: float
    folder: str
    wide: list[dict] = field(default_factory=list)  # wide rows (column → value)
    audit: list[dict] | None = None  # the session's audit rows; None: the data directory has no access log
    devices_off: dict = field(default_factory=dict)  # (trial id, attempt) → devices off while it was recorded

    @property
    def trajectories(self) -> list[tuple[dict, dict]]:
        """(trial, attempt info) of every attempt with samples."""
        return [(t, a) for t in self.trials for a in t["attempts"] if a["samples"]]


# The plan's kind of a practice trial is `trial` (the thesis's phase name, server/experiment/plan.py);
# in the exported files it says what it is.
EXPORTED_KIND = {"trial": "practice"}


def _load(reader: Reader, session: dict) -> SessionData:
    sid = session["id"]
    trials, responses = reader.trials(sid), reader.responses(sid)
    for t in trials:
        t["kind"] = EXPORTED_KIND.get(t["kind"], t["kind"])
    attempts = reader.attempts(sid)
    tick_hz = session_tick_hz(session.get("config") or {})
    by_trial: dict[int, list[dict]] = {}
    for r in responses:
        by_trial.setdefault(r["trial_id"], []).append(r)
    for t in trials:
        t["duration_s"], t["duration_from"] = _duration(t, tick_hz)
        t["responses"] = {r["question"]: {"value": r["value"], "entered_by": r["entered_by"],
                                          "answered_utc": r["answered_utc"]} for r in by_trial.get(t["id"], ())}
        t["attempts"] = [{**a, "trajectory": trajectory_name(t["seq"], a["attempt"]) if a["samples"] else None}
                         for (trial_id, _), a in sorted(attempts.items()) if trial_id == t["id"]]
    data = SessionData(session, trials, responses, reader.events(sid), reader.cues(sid), tick_hz, folder_name(session))
    for e in data.events:  # the recorder's flag (server/experiment/recorder.py): a needed device was off
        if e["kind"] == "device_off":
            data.devices_off.setdefault((e["trial_id"], e["attempt"]), set()).update(e["body"].get("devices", ()))
    data.devices_off = {k: sorted(v) for k, v in data.devices_off.items()}
    data.wide = [_wide_row(data, t) for t in trials]
    return data


def _wide_row(data: SessionData, t: dict) -> dict:
    s = data.session
    current = next((a for a in t["attempts"] if a["attempt"] == t["attempt"] and a["samples"]), None)
    row = {"session": s["id"], "study": s["study_id"], "participant": s["participant"],
           "participant_index": s["participant_index"], "device": s["device"], "experimenter": s["experimenter"],
           "software_version": s["software_version"],
           **{k: t[k] for k in ("seq", "task", "kind", "index", "condition", "repetition", "status", "attempt",
                                "started_utc", "ended_utc", "started_tick", "ended_tick", "duration_s",
                                "duration_from", "reason", "scenario", "planned_duration_s")},
           "trial_device": t["device"], "device_off": ";".join(data.devices_off.get((t["id"], t["attempt"]), ())),
           "trajectory": current and current["trajectory"]}
    row.update({f"param.{k}": v for k, v in (t["params"] or {}).items()})
    row.update({f"scenario.{k}": v for k, v in (t["scenario_params"] or {}).items()})
    for q in t["questions"] or ():
        row[f"response.{q}"] = None  # asked: a column even while unanswered
    row.update({f"response.{q}": r["value"] for q, r in t["responses"].items()})
    row.update({f"metric.{k}": v for k, v in (t["metrics"] or {}).items()})
    return row


def wide_columns(rows: Iterable[dict]) -> list[str]:
    """The fixed columns, then per group (param, scenario, response, metric) the union of the
    names over all rows, sorted: the same order in every session's file."""
    names: dict[str, set] = {g: set() for g in WIDE_GROUPS}
    for row in rows:
        for key in row:
            group, dot, name = key.partition(".")
            if dot and group in names:
                names[group].add(name)
    return list(WIDE_COLUMNS) + [f"{g}.{n}" for g in WIDE_GROUPS for n in sorted(names[g])]


def session_document(data: SessionData) -> dict:
    """session.json: everything about the session except the samples and cues (their CSVs)."""
    return {"format": FORMAT, "format_version": FORMAT_VERSION, "exported_by": f"viestac {__version__}",
            "tick_hz": data.tick_hz, "session": data.session,
            "trials": [{k: v for k, v in t.items() if k != "session_id"} for t in data.trials],
            "events": [{k: e[k] for k in ("id", "seq", "trial_id", "attempt", "tick", "utc", "kind", "body")}
                       for e in data.events]}


# -- staging and committing -----------------------------------------------------------------------
class _Staging:
    """Files written into a hidden directory inside OUT, moved into place at commit."""

    def __init__(self, out: Path):
        self.out = out
        self.dir = Path(tempfile.mkdtemp(prefix=".viestac-export-", dir=out))
        self.files: list[str] = []  # paths relative to OUT

    def _open(self, rel: str):
        path = self.dir / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        self.files.append(rel)
        return open(path, "w", newline="", encoding="utf-8")

    def csv(self, rel: str, header: Iterable[str], rows: Iterable[Iterable[Any]]) -> None:
        with self._open(rel) as f:
            w = csv.writer(f, lineterminator="\n")
            w.writerow(header)
            w.writerows([cell(v) for v in row] for row in rows)
            f.flush()
            os.fsync(f.fileno())

    def text(self, rel: str, text: str) -> None:
        with self._open(rel) as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())

    def cleanup(self) -> None:
        shutil.rmtree(self.dir, ignore_errors=True)


def _existing(out: Path, folder: str) -> list[str]:
    """Files of an earlier export in OUT/folder (only the names an export writes)."""
    base = out / folder
    found = [f"{folder}/{name}" for name in SESSION_FILES if (base / name).is_file()]
    if (base / "trajectories").is_dir():
        found += sorted(f"{folder}/trajectories/{p.name}" for p in (base / "trajectories").iterdir()
                        if p.is_file() and _TRAJECTORY_FILE.match(p.name))
    return found


def audit_rows(db_path: Path, session_ids: list[str]) -> dict[str, list[dict]] | None:
    """The audit rows of each session from the access log beside the database (None: no log)."""
    path = Path(db_path).parent / ACCESS_DB_NAME
    if not path.is_file():
        return None
    from server.auth.audit import Audit
    from server.auth.store import AccessStore

    store = AccessStore.open(path)
    try:
        audit = Audit(store)
        return {sid: audit.rows(session_id=sid, limit=MAX_AUDIT_ROWS) for sid in session_ids}
    finally:
        store.close()


def _write_session(stage: _Staging, reader: Reader, data: SessionData) -> None:
    d = data.folder
    cols = wide_columns(data.wide)
    stage.csv(f"{d}/trials_wide.csv", cols, ([row.get(c) for c in cols] for row in data.wide))
    trials = {t["id"]: t for t in data.trials}
    s = data.session
    stage.csv(f"{d}/responses_long.csv", LONG_COLUMNS, (
        (s["id"], s["study_id"], s["participant"], s["participant_index"], r["seq"], trials[r["trial_id"]]["task"],
         trials[r["trial_id"]]["kind"], trials[r["trial_id"]]["index"], trials[r["trial_id"]]["condition"],
         trials[r["trial_id"]]["repetition"], trials[r["trial_id"]]["status"], r["question"], r["value"],
         _json(r["value"]), r["entered_by"], r["answered_utc"]) for r in data.responses))
    stage.csv(f"{d}/cues.csv", CUE_COLUMNS, ((c["seq"], c["attempt"], c["tick"], _json(c["cues"])) for c in data.cues))
    stage.csv(f"{d}/events.csv", EVENT_COLUMNS, ((e["seq"], e["attempt"], e["tick"], e["utc"], e["kind"],
                                                  _json(e["body"])) for e in data.events))
    if data.audit is not None:
        stage.csv(f"{d}/audit.csv", AUDIT_COLUMNS, ((r["id"], r["utc"], r["token_id"], r["role"], r["site"], r["action"],
                                                    r["target"], r["result"],
                                                    None if r["detail"] is None else _json(r["detail"]))
                                                   for r in data.audit))
    hz = data.tick_hz
    for t, a in data.trajectories:
        stage.csv(f"{d}/{a['trajectory']}", TRAJECTORY_HEADER,
                  ((r[0], round(r[0] / hz, 9), *tuple(r)[1:]) for r in reader.samples(t["id"], a["attempt"])))
        point_rows = reader.point_samples(t["id"], a["attempt"])
        if point_rows:
            _write_points(stage, f"{d}/{a['trajectory'][:-len('.csv')]}_points.csv", point_rows, hz)
    stage.text(f"{d}/session.json", json.dumps(_finite(session_document(data)), indent=2, ensure_ascii=False,
                                               allow_nan=False) + "\n")


def _write_points(stage: _Staging, name: str, rows: list[tuple[int, dict]], hz: float) -> None:
    """The multi-point CSV (server/core/records.py): `t`, then x, y, z of every point that was
    tracked in the attempt, in the order of server/core/points.py; empty where a point was not."""
    seen = {point for _, points in rows for point in points}
    names = [p for p in POINT_NAMES if p in seen]
    stage.csv(name, multipoint_columns(names), (
        (round(tick / hz, 9), *(v for p in names for v in (points.get(p) or (None, None, None))))
        for tick, points in rows))


def _commit(stage: _Staging, folders: list[str], force: bool) -> dict[str, dict[str, list[str]]]:
    """Compare the staged files with OUT, refuse a different earlier export unless `force`, then
    move the new and changed files into place. Returns per folder ('' = OUT itself) the files
    written, unchanged and removed."""
    out = stage.out
    staged = set(stage.files)
    old = {rel for f in folders for rel in _existing(out, f)}
    if ALL_WIDE in staged and (out / ALL_WIDE).is_file():
        old.add(ALL_WIDE)
    changed = sorted(rel for rel in staged & old if not filecmp.cmp(stage.dir / rel, out / rel, shallow=False))
    stale = sorted(old - staged)
    if (changed or stale) and not force:
        by_folder: dict[str, list[str]] = {}
        for rel in changed + stale:
            by_folder.setdefault(rel.split("/", 1)[0] if "/" in rel else "", []).append(rel)
        parts = []
        for folder, rels in sorted(by_folder.items()):
            names = [r.split("/", 1)[1] if folder else r for r in rels]
            shown = ", ".join(names[:5]) + (f" and {len(names) - 5} more" if len(names) > 5 else "")
            parts.append(f"{out / folder if folder else out} already holds a different export ({shown})")
        raise ExportError("; ".join(parts) + "; pass --force to replace it")
    report: dict[str, dict[str, list[str]]] = {}

    def note(rel: str, what: str) -> None:
        folder = rel.split("/", 1)[0] if "/" in rel else ""
        report.setdefault(folder, {"written": [], "unchanged": [], "removed": []})[what].append(rel)

    for rel in stage.files:
        if rel in old and rel not in changed:
            note(rel, "unchanged")
            continue
        target = out / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        os.replace(stage.dir / rel, target)
        note(rel, "written")
    for rel in stale:
        (out / rel).unlink()
        note(rel, "removed")
    return report


# -- the export -----------------------------------------------------------------------------------
def export(db_path: str | Path, out: str | Path, session_id: str | None = None, *, all_sessions: bool = False,
           force: bool = False, site: str | None = None) -> list[dict]:
    """Export one session (`session_id`) or every session (`all_sessions`, plus all_trials_wide.csv)
    from the database at `db_path` into `out`. Returns one summary per session (and one for
    all_trials_wide.csv). Raises ExportError for a missing database, an unknown session, an
    unwritable `out`, or a different earlier export in the way (without `force`). `site`: only
    that lab's sessions (another site's session is unknown to it)."""
    if (session_id is None) == (not all_sessions):
        raise ExportError("give either a session id or --all")
    out = Path(out)
    with Reader(db_path) as reader:
        sessions = reader.sessions()
        if site is not None:
            sessions = [s for s in sessions if s.get("site") == site]
        if not all_sessions:
            chosen = [s for s in sessions if s["id"] == session_id]
            if not chosen:
                raise ExportError(f"unknown session {session_id!r}; {known_sessions(sessions)}")
        else:
            chosen = sessions
        audits = audit_rows(Path(db_path), [s["id"] for s in chosen])
        try:
            out.mkdir(parents=True, exist_ok=True)
            stage = _Staging(out)
        except OSError as exc:
            raise ExportError(f"cannot write to {out}: {exc.strerror or exc}") from None
        try:
            loaded = []
            for s in chosen:
                data = _load(reader, s)
                data.audit = None if audits is None else audits[s["id"]]
                _write_session(stage, reader, data)
                loaded.append(data)
            if all_sessions:
                # trajectory paths are relative to the file that names them
                rows = [{**row, "trajectory": row["trajectory"] and f"{data.folder}/{row['trajectory']}"}
                        for data in loaded for row in data.wide]
                cols = wide_columns(rows)
                stage.csv(ALL_WIDE, cols, ([row.get(c) for c in cols] for row in rows))
            report = _commit(stage, [d.folder for d in loaded], force)
        except OSError as exc:
            raise ExportError(f"cannot write to {out}: {exc.strerror or exc}") from None
        finally:
            stage.cleanup()
    summaries = []
    for data in loaded:
        files = report.get(data.folder, {"written": [], "unchanged": [], "removed": []})
        summaries.append({"session": data.session["id"], "dir": str(out / data.folder), "trials": len(data.trials),
                          "responses": len(data.responses), "trajectories": len(data.trajectories),
                          "written": len(files["written"]), "unchanged": len(files["unchanged"]),
                          "removed": len(files["removed"])})
    if all_sessions:
        files = report.get("", {"written": [], "unchanged": []})
        summaries.append({"session": None, "dir": str(out), "file": str(out / ALL_WIDE),
                          "trials": sum(len(d.trials) for d in loaded), "written": len(files["written"]),
                          "unchanged": len(files["unchanged"]), "removed": 0})
    return summaries

