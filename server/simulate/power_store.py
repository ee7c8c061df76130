"""Where a power analysis keeps its finished replications: OUT/replications.sqlite.

One row per (N, replication), written by the driver as each replication finishes, so an
interrupted run loses at most the replications still running and a rerun computes only the
missing ones. The configuration the rows belong to (the study file's hash, the seed, the effect
settings, the format) is stored once; a rerun with another configuration is refused rather
than mixed in. Only the driver process writes (the workers return results to it).
"""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

FORMAT = "viestac-power-replications/1"


class ConfigMismatch(ValueError):
    """OUT holds replications of another configuration."""


class ReplicationStore:
    def __init__(self, path: str | Path, config: dict):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.con = sqlite3.connect(self.path)
        self.con.executescript("""
            CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
            CREATE TABLE IF NOT EXISTS replications (
                n INTEGER NOT NULL, rep INTEGER NOT NULL, seed TEXT NOT NULL, result_json TEXT NOT NULL,
                PRIMARY KEY (n, rep));
        """)
        text = json.dumps({"format": FORMAT, **config}, sort_keys=True)
        row = self.con.execute("SELECT value FROM meta WHERE key = 'config'").fetchone()
        if row is None:
            with self.con:
                self.con.execute("INSERT INTO meta VALUES ('config', ?)", (text,))
        elif row[0] != text:
            self.con.close()
            stored, wanted = json.loads(row[0]), json.loads(text)
            differ = sorted(k for k in stored.keys() | wanted.keys() if stored.get(k) != wanted.get(k))
            raise ConfigMismatch(f"{self.path} holds replications of another configuration ({', '.join(differ)} "
                                 "differ): use a new --out")

    def done(self) -> set[tuple[int, int]]:
        return set(self.con.execute("SELECT n, rep FROM replications").fetchall())

    def add(self, n: int, rep: int, seed: int, result: dict) -> None:
        with self.con:  # one transaction per replication: a crash never leaves half a row
            self.con.execute("INSERT INTO replications VALUES (?, ?, ?, ?)",
                             (n, rep, str(seed), json.dumps(result, sort_keys=True, allow_nan=False)))

    def results(self, participants, replications: int) -> dict[tuple[int, int], dict]:
        """{(n, rep): result} of the grid's stored replications, in grid order."""
        rows = {(n, rep): json.loads(text) for n, rep, text in
                self.con.execute("SELECT n, rep, result_json FROM replications")}
        return {(n, r): rows[n, r] for n in participants for r in range(replications) if (n, r) in rows}

    def close(self) -> None:
        self.con.close()
