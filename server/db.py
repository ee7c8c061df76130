"""SQLite helpers shared by the stores (access.sqlite: server/auth/store.py; the experiment
database: server/experiment/store.py). Both open one connection in autocommit mode
(isolation_level=None) shared by threads under a lock, and write in explicit transactions."""

from __future__ import annotations

import sqlite3
from contextlib import contextmanager
from typing import ContextManager, Iterator


@contextmanager
def transaction(db: sqlite3.Connection, lock: ContextManager) -> Iterator[sqlite3.Connection]:
    """One committed transaction, under `lock` (BEGIN IMMEDIATE: the write lock up front, so two
    writers never deadlock upgrading a read lock); rolled back on any exception."""
    with lock:
        db.execute("BEGIN IMMEDIATE")
        try:
            yield db
        except BaseException:
            db.execute("ROLLBACK")
            raise
        db.execute("COMMIT")
