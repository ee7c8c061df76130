"""The experiment store: sessions, trials, responses, events, trajectories and cue commands in
SQLite, crash-safe.

Durability (the kill test, issue 6): the database runs in WAL mode; every lifecycle change
(a trial started, answered, aborted, excluded; a response) is its own committed transaction, so a
`kill -9` of the server loses at most the rows of the running trial that the recorder had not yet
flushed, never a completed trial. On open, a trial left `running` by a crash goes back to
`pending` with its attempt counted and an `interrupted` event, so the session resumes at it.
(WAL with synchronous=NORMAL is durable against a process crash; only an OS crash or power loss
can lose the last transactions, and never corrupts the file: sqlite.org/wal.html.)

Trial lifecycle: pending → running → answered | aborted; answered | aborted → excluded (with a
reason); aborted → pending again (retry: a new attempt). A psychophysics task's reserved trials
left when its procedure finishes go pending → excluded (`skip`, reason "procedure finished"). Data rows carry their attempt, so an
aborted or interrupted attempt's samples stay apart from the one that counted.

One connection, shared by the REST threads and the recorder, behind a lock: SQLite serialises
writers anyway, and a lab's data rate (≤ 1 kHz samples in batches) is far below its limits.
"""

from __future__ import annotations

import json
import sqlite3
import threading
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, ContextManager, Iterable

from server.core.records import TRAJECTORY_COLUMNS
from server.db import transaction

SCHEMA_VERSION = 1
TRIAL_STATUSES = ("pending", "running", "answered", "aborted", "excluded")
SESSION_STATUSES = ("open", "completed")
TRANSITIONS = {  # status → the statuses it may change to
    "pending": {"running"},
    "running": {"answered", "aborted"},
    "answered": {"excluded"},
    "aborted": {"excluded", "pending"},
    "excluded": set(),
}

SCHEMA = f"""
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS sessions (
    id TEXT PRIMARY KEY,
    study_id TEXT NOT NULL, study_title TEXT NOT NULL, study_hash TEXT NOT NULL, study_text TEXT NOT NULL,
    participant TEXT NOT NULL,            -- pseudonymous code, never a name
    participant_index INTEGER NOT NULL,   -- row of the study's counterbalancing
    device TEXT, experimenter TEXT NOT NULL, notes TEXT NOT NULL DEFAULT '',
    status TEXT NOT NULL CHECK (status IN {SESSION_STATUSES}),
    created_utc TEXT NOT NULL, software_version TEXT NOT NULL, config_json TEXT NOT NULL,
    site TEXT,                            -- the lab the session belongs to (NULL: the admin's)
    UNIQUE (study_id, participant)
);
CREATE TABLE IF NOT EXISTS trials (
    id INTEGER PRIMARY KEY,
    session_id TEXT NOT NULL REFERENCES sessions(id),
    seq INTEGER NOT NULL, task TEXT NOT NULL, kind TEXT NOT NULL, idx INTEGER NOT NULL,
    scenario TEXT NOT NULL, scenario_params_json TEXT NOT NULL, device TEXT, params_json TEXT NOT NULL,
    condition INTEGER, repetition INTEGER NOT NULL, duration_s REAL, questions_json TEXT NOT NULL,
    status TEXT NOT NULL CHECK (status IN {TRIAL_STATUSES}),
    attempt INTEGER NOT NULL DEFAULT 0,   -- counts starts: 1 after the first
    started_utc TEXT, started_tick INTEGER, ended_utc TEXT, ended_tick INTEGER,
    metrics_json TEXT NOT NULL DEFAULT '{{}}', reason TEXT NOT NULL DEFAULT '',
    UNIQUE (session_id, seq)
);
CREATE TABLE IF NOT EXISTS responses (
    id INTEGER PRIMARY KEY,
    trial_id INTEGER NOT NULL REFERENCES trials(id),
    question TEXT NOT NULL, value_json TEXT NOT NULL, entered_by TEXT NOT NULL, answered_utc TEXT NOT NULL,
    UNIQUE (trial_id, question)
);
CREATE TABLE IF NOT EXISTS events (
    id INTEGER PRIMARY KEY,
    session_id TEXT NOT NULL, trial_id INTEGER, attempt INTEGER,
    utc TEXT NOT NULL, tick INTEGER, kind TEXT NOT NULL, body_json TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS samples (      -- trajectories: tick rate or decimated
    trial_id INTEGER NOT NULL, attempt INTEGER NOT NULL, tick INTEGER NOT NULL,
    hip_x REAL, hip_y REAL, hip_z REAL, proxy_x REAL, proxy_y REAL, proxy_z REAL, contact INTEGER,
    held TEXT, held_x REAL, held_y REAL, held_z REAL,
    PRIMARY KEY (trial_id, attempt, tick)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS cues (         -- device cue commands, whenever they changed
    trial_id INTEGER NOT NULL, attempt INTEGER NOT NULL, tick INTEGER NOT NULL, cues_json TEXT NOT NULL,
    PRIMARY KEY (trial_id, attempt, tick)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS point_samples (  -- several tracked points (fingers, a hand): server/core/records.py
    trial_id INTEGER NOT NULL, attempt INTEGER NOT NULL, tick INTEGER NOT NULL, points_json TEXT NOT NULL,
    PRIMARY KEY (trial_id, attempt, tick)
) WITHOUT ROWID;
CREATE INDEX IF NOT EXISTS events_by_trial ON events (trial_id, attempt);
CREATE INDEX IF NOT EXISTS trials_by_status ON trials (session_id, status);
"""

SAMPLE_COLUMNS = TRAJECTORY_COLUMNS  # the loop's trajectory rows go in as they come


def utc_now() -> str:
    """The server's wall clock, UTC, ISO 8601 with microseconds (the store's default clock)."""
    return datetime.now(timezone.utc).isoformat(timespec="microseconds")


class StoreError(ValueError):
    """A request the data does not allow (unknown session, a transition the lifecycle forbids)."""


class Conflict(StoreError):
    """The session is not in the state the request expected (someone else moved it on)."""


@dataclass(frozen=True)
class TrialRow:
    id: int
    session_id: str
    seq: int
    task: str
    kind: str
    index: int
    scenario: str
    scenario_params: dict
    device: str | None
    params: dict
    condition: int | None
    repetition: int
    duration_s: float | None
    questions: tuple[str, ...]
    status: str
    attempt: int
    started_utc: str | None
    started_tick: int | None
    ended_utc: str | None
    ended_tick: int | None
    metrics: dict
    reason: str

    def to_dict(self) -> dict:
        d = dict(self.__dict__)
        d["questions"] = list(self.questions)
        return d


_ENCODER = json.JSONEncoder(separators=(",", ":"), sort_keys=True)  # json.dumps would build one per call


def _dumps(value: Any) -> str:
    return _ENCODER.encode(value)


def _trial(row: sqlite3.Row) -> TrialRow:
    return TrialRow(row["id"], row["session_id"], row["seq"], row["task"], row["kind"], row["idx"], row["scenario"],
                    json.loads(row["scenario_params_json"]), row["device"], json.loads(row["params_json"]),
                    row["condition"], row["repetition"], row["duration_s"], tuple(json.loads(row["questions_json"])),
                    row["status"], row["attempt"], row["started_utc"], row["started_tick"], row["ended_utc"],
                    row["ended_tick"], json.loads(row["metrics_json"]), row["reason"])


class Store:
    """The SQLite adapter. `utc` is injected (a function returning an ISO-8601 UTC string) so
    tests and replays control time."""

    def __init__(self, path: str | Path, utc):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.utc = utc
        self._lock = threading.RLock()
        self.db = sqlite3.connect(self.path, check_same_thread=False, isolation_level=None)
        self.db.row_factory = sqlite3.Row
        self.db.execute("PRAGMA journal_mode=WAL")
        self.db.execute("PRAGMA synchronous=NORMAL")
        self.db.execute("PRAGMA foreign_keys=ON")
        self.db.executescript(SCHEMA)
        self._migrate()
        self.db.execute("INSERT OR IGNORE INTO meta VALUES ('schema_version', ?)", (str(SCHEMA_VERSION),))
        self.interrupted = self._recover()

    def close(self) -> None:
        with self._lock:
            self.db.close()

    def _tx(self) -> ContextManager[sqlite3.Connection]:
        """One committed transaction (server/db.py)."""
        return transaction(self.db, self._lock)

    def _migrate(self) -> None:
        """Columns added since a database was made: sessions.site (per-lab data)."""
        columns = {r["name"] for r in self.db.execute("PRAGMA table_info(sessions)")}
        if "site" not in columns:
            self.db.execute("ALTER TABLE sessions ADD COLUMN site TEXT")

    def _recover(self) -> list[TrialRow]:
        """Trials a crash left running go back to pending (their attempt stays counted)."""
        with self._tx() as db:
            rows = [_trial(r) for r in db.execute("SELECT * FROM trials WHERE status = 'running'")]
            for t in rows:
                self._interrupt(db, t, "server restart", None)
        return rows

    def interrupt(self, trial_id: int, reason: str, tick: int | None = None) -> TrialRow:
        """A running trial whose attempt could not go on (the loop restarted): back to pending, its
        attempt counted and its rows kept, with an `interrupted` event, as after a server crash."""
        with self._tx() as db:
            row = db.execute("SELECT * FROM trials WHERE id = ?", (trial_id,)).fetchone()
            if row is None:
                raise StoreError(f"unknown trial {trial_id}")
            if row["status"] != "running":
                raise Conflict(f"trial {row['seq']} is {row['status']}, not running")
            self._interrupt(db, _trial(row), reason, tick)
        return self.trial(trial_id)

    def _interrupt(self, db: sqlite3.Connection, t: TrialRow, reason: str, tick: int | None) -> None:
        db.execute("UPDATE trials SET status = 'pending', reason = 'interrupted' WHERE id = ?", (t.id,))
        db.execute("INSERT INTO events (session_id, trial_id, attempt, utc, tick, kind, body_json) "
                   "VALUES (?, ?, ?, ?, ?, 'interrupted', ?)",
                   (t.session_id, t.id, t.attempt, self.utc(), tick, _dumps({"reason": reason})))

    def append_database(self, path: str | Path) -> None:
        """Every row of another store's database, after this one's, in one transaction: as if its
        rows had been written here after every row already here. Its trials, events and responses
        are renumbered from this store's highest ids (SQLite gives a new row max(id) + 1: the id
        each would have got here), and the rows that name a trial follow. A simulated study runs
        its participants in separate processes, each into its own database, and appends them in
        participant order (server/simulate/study_run.py). The meta table is not copied."""
        with self._lock:
            self.db.execute("ATTACH DATABASE ? AS part", (str(path),))
            try:
                with self._tx() as db:
                    offset = {t: db.execute(f"SELECT COALESCE(MAX(id), 0) FROM main.{t}").fetchone()[0]
                              for t in ("trials", "events", "responses")}
                    renumber = {"trials": {"id": offset["trials"]},
                                "events": {"id": offset["events"], "trial_id": offset["trials"]},
                                "responses": {"id": offset["responses"], "trial_id": offset["trials"]}}
                    for table in ("sessions", "trials", "responses", "events", "samples", "cues", "point_samples"):
                        shift = renumber.get(table, {"trial_id": offset["trials"]})
                        columns = [r["name"] for r in db.execute(f"PRAGMA main.table_info({table})")]
                        select = ", ".join(f"{c} + {shift[c]}" if c in shift else c for c in columns)
                        order = "rowid" if table == "sessions" else "id" if "id" in columns else "trial_id, attempt, tick"
                        db.execute(f"INSERT INTO main.{table} ({', '.join(columns)}) "
                                   f"SELECT {select} FROM part.{table} ORDER BY {order}")
            finally:
                self.db.execute("DETACH DATABASE part")

    def integrity(self) -> str:
        with self._lock:
            return self.db.execute("PRAGMA integrity_check").fetchone()[0]

    # -- sessions ---------------------------------------------------------------------------
    def create_session(self, *, session_id: str, study_id: str, study_title: str, study_hash: str,
                       study_text: str, participant: str, participant_index: int, device: str | None,
                       experimenter: str, notes: str, software_version: str, config: dict,
                       plan: Iterable[dict], site: str | None = None) -> dict:
        """A session with its whole plan as pending trials, in one transaction."""
        try:
            with self._tx() as db:
                db.execute("INSERT INTO sessions (id, study_id, study_title, study_hash, study_text, participant, "
                           "participant_index, device, experimenter, notes, status, created_utc, software_version, "
                           "config_json, site) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, 'open', ?, ?, ?, ?)",
                           (session_id, study_id, study_title, study_hash, study_text, participant,
                            participant_index, device, experimenter, notes, self.utc(), software_version,
                            _dumps(config), site))
                db.executemany(
                    "INSERT INTO trials (session_id, seq, task, kind, idx, scenario, scenario_params_json, device, "
                    "params_json, condition, repetition, duration_s, questions_json, status) "
                    "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, 'pending')",
                    [(session_id, p["seq"], p["task"], p["kind"], p["index"], p["scenario"],
                      _dumps(p["scenario_params"]), p.get("device"), _dumps(p["params"]), p.get("condition"),
                      p.get("repetition", 0), p.get("duration_s"), _dumps(list(p.get("questions", ()))))
                     for p in plan])
        except sqlite3.IntegrityError as exc:
            if "sessions.study_id, sessions.participant" in str(exc):
                raise Conflict(f"participant {participant!r} already has a session of study {study_id!r}") from None
            raise
        return self.session(session_id)

    def session(self, session_id: str) -> dict:
        with self._lock:
            row = self.db.execute("SELECT * FROM sessions WHERE id = ?", (session_id,)).fetchone()
        if row is None:
            raise StoreError(f"unknown session {session_id!r}")
        d = dict(row)
        d["config"] = json.loads(d.pop("config_json"))
        return d

    def sessions(self, site: str | None = None) -> list[dict]:
        """Every session with its progress; only those of `site` when given."""
        where, args = ("WHERE s.site = ? ", (site,)) if site is not None else ("", ())
        with self._lock:
            rows = self.db.execute(
                "SELECT s.id, s.study_id, s.participant, s.participant_index, s.device, s.experimenter, s.status, "
                "s.created_utc, s.site, COUNT(t.id) AS trials, "
                "SUM(t.status IN ('answered', 'aborted', 'excluded')) AS done "
                f"FROM sessions s LEFT JOIN trials t ON t.session_id = s.id {where}GROUP BY s.id "
                "ORDER BY s.created_utc", args).fetchall()
        return [dict(r) for r in rows]

    def set_session_status(self, session_id: str, status: str) -> None:
        with self._tx() as db:
            db.execute("UPDATE sessions SET status = ? WHERE id = ?", (status, session_id))

    def set_notes(self, session_id: str, notes: str) -> None:
        with self._tx() as db:
            db.execute("UPDATE sessions SET notes = ? WHERE id = ?", (notes, session_id))

    # -- trials -----------------------------------------------------------------------------
    def trials(self, session_id: str) -> list[TrialRow]:
        with self._lock:
            return [_trial(r) for r in self.db.execute(
                "SELECT * FROM trials WHERE session_id = ? ORDER BY seq", (session_id,))]

    def trial_at(self, session_id: str, seq: int) -> TrialRow | None:
        """The session's trial `seq`, or None."""
        with self._lock:
            row = self.db.execute("SELECT * FROM trials WHERE session_id = ? AND seq = ?", (session_id, seq)).fetchone()
        return None if row is None else _trial(row)

    def trial(self, trial_id: int) -> TrialRow:
        with self._lock:
            row = self.db.execute("SELECT * FROM trials WHERE id = ?", (trial_id,)).fetchone()
        if row is None:
            raise StoreError(f"unknown trial {trial_id}")
        return _trial(row)

    def running(self) -> TrialRow | None:
        with self._lock:
            row = self.db.execute("SELECT * FROM trials WHERE status = 'running'").fetchone()
        return None if row is None else _trial(row)

    def next_pending(self, session_id: str) -> TrialRow | None:
        with self._lock:
            row = self.db.execute("SELECT * FROM trials WHERE session_id = ? AND status = 'pending' "
                                  "ORDER BY seq LIMIT 1", (session_id,)).fetchone()
        return None if row is None else _trial(row)

    def transition(self, trial_id: int, status: str, *, expect: str | None = None, tick: int | None = None,
                   metrics: dict | None = None, reason: str | None = None, first_tick: int | None = None) -> TrialRow:
        """Move a trial along its lifecycle in one transaction; `expect` guards against a race
        (Conflict when the trial is no longer in that status). `tick`: the loop's tick of this
        change; `first_tick` (on ending): the tick the trial took effect in the loop, which is
        known only after it started."""
        with self._tx() as db:
            row = db.execute("SELECT * FROM trials WHERE id = ?", (trial_id,)).fetchone()
            if row is None:
                raise StoreError(f"unknown trial {trial_id}")
            current = row["status"]
            if expect is not None and current != expect:
                raise Conflict(f"trial {row['seq']} is {current}, not {expect}")
            if status not in TRANSITIONS[current]:
                raise StoreError(f"trial {row['seq']} is {current}; it cannot become {status}")
            now = self.utc()
            if status == "running":
                db.execute("UPDATE trials SET status = 'running', attempt = attempt + 1, started_utc = ?, "
                           "started_tick = ?, ended_utc = NULL, ended_tick = NULL, reason = '' WHERE id = ?",
                           (now, tick, trial_id))
                if db.execute("SELECT COUNT(*) FROM trials WHERE status = 'running'").fetchone()[0] > 1:
                    raise Conflict("another trial is already running")
            elif status in ("answered", "aborted"):
                db.execute("UPDATE trials SET status = ?, ended_utc = ?, ended_tick = ?, metrics_json = ?, "
                           "reason = ?, started_tick = COALESCE(started_tick, ?) WHERE id = ?",
                           (status, now, tick, _dumps(metrics or {}), reason or "", first_tick, trial_id))
            elif status == "excluded":
                db.execute("UPDATE trials SET status = 'excluded', reason = ? WHERE id = ?", (reason or "", trial_id))
            else:  # retry: back to pending, its responses cleared (the attempt's data stays, keyed by attempt)
                db.execute("UPDATE trials SET status = 'pending', reason = ? WHERE id = ?", (reason or "retry",
                                                                                             trial_id))
                db.execute("DELETE FROM responses WHERE trial_id = ?", (trial_id,))
            db.execute("INSERT INTO events (session_id, trial_id, attempt, utc, tick, kind, body_json) "
                       "SELECT session_id, id, attempt, ?, ?, 'lifecycle', ? FROM trials WHERE id = ?",
                       (now, tick, _dumps({"from": current, "to": status, "reason": reason or ""}), trial_id))
        return self.trial(trial_id)

    def present(self, trial_id: int, params: dict, scenario_params: dict) -> TrialRow:
        """A pending trial's parameters as it will present them (a psychophysics trial's levels are
        chosen when it starts, server/experiment/psychophysics_task.py): the export shows what ran."""
        with self._tx() as db:
            cur = db.execute("UPDATE trials SET params_json = ?, scenario_params_json = ? "
                             "WHERE id = ? AND status = 'pending'", (_dumps(params), _dumps(scenario_params), trial_id))
            if cur.rowcount != 1:
                raise Conflict(f"trial {trial_id} is not pending")
        return self.trial(trial_id)

    def skip(self, trial_id: int, reason: str) -> TrialRow:
        """A pending trial that will never run (its psychophysical procedure has finished):
        excluded with `reason` and a lifecycle event, in one transaction."""
        with self._tx() as db:
            cur = db.execute("UPDATE trials SET status = 'excluded', reason = ? WHERE id = ? AND status = 'pending'",
                             (reason, trial_id))
            if cur.rowcount != 1:
                raise Conflict(f"trial {trial_id} is not pending")
            db.execute("INSERT INTO events (session_id, trial_id, attempt, utc, tick, kind, body_json) "
                       "SELECT session_id, id, attempt, ?, NULL, 'lifecycle', ? FROM trials WHERE id = ?",
                       (self.utc(), _dumps({"from": "pending", "to": "excluded", "reason": reason}), trial_id))
        return self.trial(trial_id)

    # -- responses --------------------------------------------------------------------------
    def put_response(self, trial_id: int, question: str, value: Any, entered_by: str) -> None:
        """Record (or correct) one answer; the last value entered counts."""
        with self._tx() as db:
            db.execute("INSERT INTO responses (trial_id, question, value_json, entered_by, answered_utc) "
                       "VALUES (?, ?, ?, ?, ?) ON CONFLICT (trial_id, question) DO UPDATE SET "
                       "value_json = excluded.value_json, entered_by = excluded.entered_by, "
                       "answered_utc = excluded.answered_utc",
                       (trial_id, question, _dumps(value), entered_by, self.utc()))

    def responses(self, trial_id: int) -> dict[str, Any]:
        with self._lock:
            return {r["question"]: json.loads(r["value_json"]) for r in self.db.execute(
                "SELECT question, value_json FROM responses WHERE trial_id = ? ORDER BY question", (trial_id,))}

    # -- recorded streams (batched by the recorder) -------------------------------------------
    def add_events(self, rows: list[tuple]) -> None:
        """rows: (session_id, trial_id | None, attempt | None, tick | None, kind, body dict)."""
        if not rows:
            return
        now = self.utc()
        with self._tx() as db:
            db.executemany("INSERT INTO events (session_id, trial_id, attempt, utc, tick, kind, body_json) "
                           "VALUES (?, ?, ?, ?, ?, ?, ?)",
                           [(s, t, a, now, tick, kind, _dumps(body)) for s, t, a, tick, kind, body in rows])

    def add_samples(self, trial_id: int, attempt: int, rows: list[tuple]) -> None:
        """rows in SAMPLE_COLUMNS order; a tick recorded twice keeps its first row."""
        if rows:
            with self._tx() as db:
                db.executemany(f"INSERT OR IGNORE INTO samples VALUES (?, ?, {', '.join('?' * len(SAMPLE_COLUMNS))})",
                               [(trial_id, attempt, *r) for r in rows])

    def add_point_samples(self, trial_id: int, attempt: int, rows) -> None:
        """[tick, {point: [x, y, z]}] rows (server/core/records.py POINT_ROW); a tick twice keeps its first."""
        if rows:
            with self._tx() as db:
                db.executemany("INSERT OR IGNORE INTO point_samples VALUES (?, ?, ?, ?)",
                               [(trial_id, attempt, tick, _dumps(points)) for tick, points in rows])

    def point_samples(self, trial_id: int, attempt: int) -> list[tuple[int, dict]]:
        with self._lock:
            return [(r["tick"], json.loads(r["points_json"])) for r in self.db.execute(
                "SELECT tick, points_json FROM point_samples WHERE trial_id = ? AND attempt = ? ORDER BY tick",
                (trial_id, attempt))]

    def add_cues(self, trial_id: int, attempt: int, rows: list[tuple[int, list]]) -> None:
        if rows:
            with self._tx() as db:
                db.executemany("INSERT OR REPLACE INTO cues VALUES (?, ?, ?, ?)",
                               [(trial_id, attempt, tick, _dumps(cues)) for tick, cues in rows])

    def events(self, session_id: str, trial_id: int | None = None) -> list[dict]:
        sql, args = "SELECT * FROM events WHERE session_id = ?", [session_id]
        if trial_id is not None:
            sql, args = sql + " AND trial_id = ?", args + [trial_id]
        with self._lock:
            rows = self.db.execute(sql + " ORDER BY id", args).fetchall()
        return [{**{k: r[k] for k in r.keys() if k != "body_json"}, "body": json.loads(r["body_json"])} for r in rows]

    def devices_off(self, session_id: str) -> dict[tuple[int, int], list[str]]:
        """(trial id, attempt) → the devices a trial needed that were off while it was recorded
        (the recorder's `device_off` events, docs/data.md), sorted."""
        with self._lock:
            rows = self.db.execute("SELECT trial_id, attempt, body_json FROM events WHERE session_id = ? "
                                   "AND kind = 'device_off'", (session_id,)).fetchall()
        out: dict[tuple[int, int], set] = {}
        for r in rows:
            out.setdefault((r["trial_id"], r["attempt"]), set()).update(json.loads(r["body_json"]).get("devices", ()))
        return {k: sorted(v) for k, v in out.items()}

    def samples(self, trial_id: int, attempt: int | None = None) -> list[dict]:
        sql, args = "SELECT * FROM samples WHERE trial_id = ?", [trial_id]
        if attempt is not None:
            sql, args = sql + " AND attempt = ?", args + [attempt]
        with self._lock:
            return [dict(r) for r in self.db.execute(sql + " ORDER BY attempt, tick", args)]
