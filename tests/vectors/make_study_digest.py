"""Writes tests/vectors/study_digest.json: a digest of every table of one simulated thesis
participant's database (`studies/thesis-2021.toml`, seed 1, SIM00), made by the code before the
speed work of issue 23 (commit 2d3af1a). tests/simulate/test_same_results.py runs the current code
and compares, so a faster tick or device path that changes one recorded number fails there.

Run from a checkout of the code the digest should stand for:
    PYTHONPATH=. python tests/vectors/make_study_digest.py
A change that is meant to change the recorded data regenerates it (and says so in its commit).
"""

from __future__ import annotations

import hashlib
import json
import sqlite3
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).parent
ROOT = HERE.parent.parent
STUDY, SEED, PARTICIPANTS = "studies/thesis-2021.toml", 1, 1


def table_digests(db: Path) -> dict[str, list]:
    """{table: [rows, sha256 of the rows]}: rows in insertion order, each session id (a random
    uuid4 in every run) replaced by its participant code."""
    con = sqlite3.connect(db)
    try:
        code = dict(con.execute("SELECT id, participant FROM sessions"))
        out = {}
        for table, sql in con.execute("SELECT name, sql FROM sqlite_master WHERE type = 'table' ORDER BY name"):
            # a WITHOUT ROWID table is read in its primary key's order, the others in insertion order
            order = "" if "WITHOUT ROWID" in sql.upper() else " ORDER BY rowid"
            h, n = hashlib.sha256(), 0
            for row in con.execute(f"SELECT * FROM {table}{order}"):  # noqa: S608 - table names from the db
                h.update(repr([code.get(v, v) if isinstance(v, str) else v for v in row]).encode())
                n += 1
            out[table] = [n, h.hexdigest()]
        return out
    finally:
        con.close()


def simulate(out_dir: Path) -> Path:
    """One thesis participant, as `viestac study --simulate` runs it; the database's path."""
    from server.simulate.effects import parse_settings
    from server.simulate.study_run import simulate_study

    people = parse_settings([])
    simulate_study(ROOT / STUDY, participants=PARTICIPANTS, seed=SEED, out_dir=out_dir,
                   make_participant=people.participant, agent_params=people.agent, workers=1)
    return out_dir / "data" / "viestac.sqlite"


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    with tempfile.TemporaryDirectory() as tmp:
        digests = table_digests(simulate(Path(tmp)))
    (HERE / "study_digest.json").write_text(json.dumps(
        {"study": STUDY, "seed": SEED, "participants": PARTICIPANTS, "tables": digests}, indent=2) + "\n")
