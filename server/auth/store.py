"""The access-control database, DATA_DIR/access.sqlite (WAL): tokens, single-use codes, the lease,
the audit log; and the server key in DATA_DIR/access.key (0600, never in the database).

Thin I/O: no decision is made here. One connection per object behind one lock, because REST
handlers run in a thread pool and write audit rows. The CLI opens the same file while a server runs;
SQLite's WAL lets both write, and `data_version` tells one connection that another committed.
"""

from __future__ import annotations

import json
import os
import secrets
import sqlite3
import threading
from pathlib import Path
from typing import ContextManager

from server.db import transaction

KEY_BYTES = 32
MAX_AUDIT_ROWS = 10_000  # one read of the audit log at most

SCHEMA = """
CREATE TABLE IF NOT EXISTS tokens (
    token_id TEXT PRIMARY KEY,
    digest TEXT NOT NULL UNIQUE,       -- HMAC-SHA256(server key, secret), hex
    role TEXT NOT NULL,
    site TEXT,
    session TEXT,
    label TEXT NOT NULL DEFAULT '',
    created_at REAL NOT NULL,
    expires_at REAL,
    revoked_at REAL,
    created_by TEXT
);
CREATE TABLE IF NOT EXISTS codes (
    digest TEXT PRIMARY KEY,           -- HMAC-SHA256(server key, code), hex
    kind TEXT NOT NULL,                -- login | join
    role TEXT NOT NULL,
    site TEXT,
    session TEXT,
    created_at REAL NOT NULL,
    expires_at REAL NOT NULL,
    used_at REAL,
    created_by TEXT
);
CREATE TABLE IF NOT EXISTS lease (
    id INTEGER PRIMARY KEY CHECK (id = 1),
    record TEXT NOT NULL               -- Lease.to_record() as JSON
);
CREATE TABLE IF NOT EXISTS audit (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    utc REAL NOT NULL,
    token_id TEXT,
    role TEXT,
    site TEXT,
    action TEXT NOT NULL,
    target TEXT NOT NULL,
    result TEXT NOT NULL,
    session_id TEXT,
    detail TEXT                        -- JSON or NULL
);
CREATE INDEX IF NOT EXISTS audit_session ON audit (session_id);
CREATE INDEX IF NOT EXISTS audit_site ON audit (site);
"""

TOKEN_FIELDS = ("token_id", "digest", "role", "site", "session", "label", "created_at", "expires_at", "revoked_at",
                "created_by")
CODE_FIELDS = ("digest", "kind", "role", "site", "session", "created_at", "expires_at", "used_at", "created_by")


def load_key(path: str | Path) -> bytes:
    """The server key: 32 random bytes, created on first use with mode 0600. A key file readable
    by others is tightened to 0600 (it lets anyone who reads it check guessed tokens offline)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except FileExistsError:
        data = path.read_bytes()
        if len(data) != KEY_BYTES:
            raise ValueError(f"{path}: a server key is {KEY_BYTES} bytes, this file has {len(data)} "
                             f"(remove it to make a new one; every token then becomes invalid)") from None
        if os.stat(path).st_mode & 0o077:
            os.chmod(path, 0o600)
        return data
    key = secrets.token_bytes(KEY_BYTES)
    with os.fdopen(fd, "wb") as f:
        f.write(key)
    return key


class AccessStore:
    """The SQLite adapter of access control. Rows go in and out as dicts."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if not self.path.exists():  # 0600 from the start; SQLite gives -wal/-shm the database's mode
            os.close(os.open(self.path, os.O_WRONLY | os.O_CREAT, 0o600))
        self._lock = threading.RLock()
        self.db = sqlite3.connect(self.path, check_same_thread=False, isolation_level=None, timeout=10.0)
        self.db.row_factory = sqlite3.Row
        self.db.execute("PRAGMA journal_mode=WAL")
        self.db.execute("PRAGMA synchronous=NORMAL")
        self.db.executescript(SCHEMA)

    @classmethod
    def open(cls, path: str | Path) -> "AccessStore":
        return cls(path)

    def close(self) -> None:
        with self._lock:
            self.db.close()

    def _tx(self) -> ContextManager[sqlite3.Connection]:
        """One committed transaction (server/db.py)."""
        return transaction(self.db, self._lock)

    def data_version(self) -> int:
        """Changes when another connection (the CLI, another process) commits to the file."""
        with self._lock:
            return self.db.execute("PRAGMA data_version").fetchone()[0]

    # ---- tokens ------------------------------------------------------------------------------
    def insert_token(self, row: dict) -> bool:
        """False when the token id or digest exists already (the caller draws a new id)."""
        try:
            with self._tx() as db:
                db.execute(f"INSERT INTO tokens ({', '.join(TOKEN_FIELDS)}) VALUES ({', '.join('?' * len(TOKEN_FIELDS))})",
                           tuple(row.get(k) for k in TOKEN_FIELDS))
        except sqlite3.IntegrityError:
            return False
        return True

    def token_by_digest(self, digest: str) -> dict | None:
        with self._lock:
            row = self.db.execute("SELECT * FROM tokens WHERE digest = ?", (digest,)).fetchone()
        return dict(row) if row else None

    def token(self, token_id: str) -> dict | None:
        with self._lock:
            row = self.db.execute("SELECT * FROM tokens WHERE token_id = ?", (token_id,)).fetchone()
        return dict(row) if row else None

    def tokens(self) -> list[dict]:
        with self._lock:
            return [dict(r) for r in self.db.execute("SELECT * FROM tokens ORDER BY created_at, token_id")]

    def revoke_token(self, token_id: str, now: float) -> bool:
        with self._tx() as db:
            cur = db.execute("UPDATE tokens SET revoked_at = ? WHERE token_id = ? AND revoked_at IS NULL",
                             (now, token_id))
        return cur.rowcount == 1

    # ---- single-use codes --------------------------------------------------------------------
    def insert_code(self, row: dict) -> None:
        with self._tx() as db:
            db.execute(f"INSERT INTO codes ({', '.join(CODE_FIELDS)}) VALUES ({', '.join('?' * len(CODE_FIELDS))})",
                       tuple(row.get(k) for k in CODE_FIELDS))

    def use_code(self, digest: str, kind: str, now: float) -> dict | None:
        """Marks a valid unused code used and returns it; None when it is unknown, of another kind,
        expired or used. One UPDATE: two redeemers of one code cannot both win. Used and expired
        codes older than a day are removed on the way."""
        with self._tx() as db:
            cur = db.execute("UPDATE codes SET used_at = ? WHERE digest = ? AND kind = ? AND used_at IS NULL "
                             "AND expires_at > ?", (now, digest, kind, now))
            row = db.execute("SELECT * FROM codes WHERE digest = ?", (digest,)).fetchone() if cur.rowcount else None
            db.execute("DELETE FROM codes WHERE expires_at < ?", (now - 86400.0,))
        return dict(row) if row else None

    # ---- the lease ---------------------------------------------------------------------------
    def save_lease(self, record: dict) -> None:
        with self._tx() as db:
            db.execute("INSERT INTO lease (id, record) VALUES (1, ?) ON CONFLICT (id) DO UPDATE SET record = excluded.record",
                       (json.dumps(record, sort_keys=True),))

    def load_lease(self) -> dict | None:
        with self._lock:
            row = self.db.execute("SELECT record FROM lease WHERE id = 1").fetchone()
        return json.loads(row[0]) if row else None

    # ---- audit -------------------------------------------------------------------------------
    def add_audit(self, row: dict) -> int:
        detail = row.get("detail")
        with self._tx() as db:
            cur = db.execute("INSERT INTO audit (utc, token_id, role, site, action, target, result, session_id, detail) "
                             "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                             (row["utc"], row.get("token_id"), row.get("role"), row.get("site"), row["action"],
                              row["target"], row["result"], row.get("session_id"),
                              None if detail is None else json.dumps(detail, sort_keys=True, default=str)))
        return cur.lastrowid

    def audit_rows(self, *, site: str | None = None, session_id: str | None = None, limit: int = 200) -> list[dict]:
        """The newest `limit` rows, oldest first, filtered by site and/or session."""
        where, args = [], []
        if site is not None:
            where.append("site = ?")
            args.append(site)
        if session_id is not None:
            where.append("session_id = ?")
            args.append(session_id)
        sql = "SELECT * FROM audit" + (" WHERE " + " AND ".join(where) if where else "") + " ORDER BY id DESC LIMIT ?"
        with self._lock:
            rows = [dict(r) for r in self.db.execute(sql, (*args, min(MAX_AUDIT_ROWS, max(0, int(limit)))))]
        for r in rows:
            r["detail"] = None if r["detail"] is None else json.loads(r["detail"])
        rows.reverse()
        return rows
