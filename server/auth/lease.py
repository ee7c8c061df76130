"""The control lease: one holder at a time controls the rig, the others wait in a FIFO queue.

Pure: no I/O; the clock (UTC seconds, wall clock because the lease survives a restart) is passed
in. The facade (server/auth/__init__.py) persists `to_record()` and publishes `snapshot()` after
every change. Everyone in it (holder and queue) renews at least every `ttl_s`, or is dropped by
`expire()`; the queue moves on. The holder may open one participant session: a participant token
of that session may drive the HIP. A new holder starts with no session open.

A lock makes each operation atomic: REST handlers run in a thread pool.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

from server.auth.identity import CONTROLLERS, Identity


@dataclass
class _Entry:
    token_id: str
    role: str
    site: str | None
    label: str
    since: float  # holding since / queued since
    seen: float   # the last request or renewal

    @classmethod
    def of(cls, who: Identity, now: float) -> "_Entry":
        return cls(who.token_id, who.role, who.site, who.label, now, now)

    def record(self) -> dict:
        return {"token_id": self.token_id, "role": self.role, "site": self.site, "label": self.label,
                "since": self.since, "seen": self.seen}


class Lease:
    def __init__(self, ttl_s: float, clock=time.time):
        if not ttl_s > 0:
            raise ValueError("the lease ttl must be positive")
        self.ttl_s = float(ttl_s)
        self.clock = clock
        self.holder: _Entry | None = None
        self.queue: list[_Entry] = []
        self.session: str | None = None
        self._lock = threading.RLock()

    # ---- requests ----------------------------------------------------------------------------
    def request(self, who: Identity) -> dict:
        """{"status": "granted" | "held" | "queued", "position": 1-based place in the queue | None}.
        Asking again renews (a queued requester keeps its place)."""
        if who.role not in CONTROLLERS:
            raise PermissionError(f"a {who.role} may not hold the control lease")
        with self._lock:
            now = self.clock()
            self._expire(now)
            if self.holder is not None and self.holder.token_id == who.token_id:
                self.holder.seen = now
                return {"status": "held", "position": None}
            for i, entry in enumerate(self.queue):
                if entry.token_id == who.token_id:
                    entry.seen = now
                    return {"status": "queued", "position": i + 1}
            if self.holder is None:
                self.holder = _Entry.of(who, now)
                self.session = None
                return {"status": "granted", "position": None}
            self.queue.append(_Entry.of(who, now))
            return {"status": "queued", "position": len(self.queue)}

    def renew(self, who: Identity) -> bool:
        """False if `who` is neither the holder nor queued (or was quiet too long)."""
        with self._lock:
            now = self.clock()
            self._expire(now)
            entry = self._find(who.token_id)
            if entry is None:
                return False
            entry.seen = now
            return True

    def renew_by_activity(self, who: Identity) -> bool:
        """The holder's own activity on the rig, or a participant's of the open session, renews the
        holder (a queued requester's /ws activity does not keep its place: it is not on the rig).
        False when `who` is neither, or the holder was quiet past the ttl already."""
        with self._lock:
            now = self.clock()
            holder = self.holder
            if holder is None or self._quiet(holder, now):
                return False
            if holder.token_id == who.token_id or (who.role == "participant" and who.session is not None
                                                   and who.session == self.session):
                holder.seen = now
                return True
            return False

    def open_for_running(self, session_id: str, site: str | None) -> bool:
        """A trial of `session_id` (of lab `site`; None: a session of no lab, the admin's) is being
        recorded: if the holder is of that lab (or the admin), that session is the open one. True if
        it changed."""
        with self._lock:
            if self.holder is None or self.session == session_id or \
                    (self.holder.role != "admin" and self.holder.site != site):
                return False
            self.session = session_id
            return True

    def release(self, who: Identity) -> bool:
        """The holder lets go (the next in the queue gets it); a queued requester leaves the queue."""
        with self._lock:
            return self._drop(who.token_id)

    def drop(self, token_id: str) -> bool:
        """A revoked token leaves the lease (holder or queue)."""
        with self._lock:
            return self._drop(token_id)

    def force_release(self) -> bool:
        """The holder loses the lease whatever it says (an admin's decision; the caller checks the role)."""
        with self._lock:
            if self.holder is None:
                return False
            self._promote(self.clock())
            return True

    def hand_over(self, who: Identity, to_token_id: str) -> bool:
        """The holder gives the lease to a queued requester (which leaves the queue; the old holder
        does not queue). False when `who` does not hold the lease; ValueError when the token is not
        in the queue."""
        with self._lock:
            now = self.clock()
            self._expire(now)
            if not self._holds(who, now):
                return False
            for i, entry in enumerate(self.queue):
                if entry.token_id == to_token_id:
                    del self.queue[i]
                    entry.since = entry.seen = now
                    self.holder = entry
                    self.session = None
                    return True
            raise ValueError(f"token {to_token_id} is not waiting for the lease")

    def open_session(self, who: Identity, session_id: str | None) -> None:
        """The holder opens the participant session whose participant may drive (None closes it)."""
        with self._lock:
            if not self._holds(who, self.clock()):
                raise PermissionError("only the lease holder opens a participant session")
            self.session = session_id

    def expire(self) -> bool:
        """Drops a quiet holder and quiet queued requesters (the next gets the lease); True if it changed."""
        with self._lock:
            return self._expire(self.clock())

    # ---- questions ---------------------------------------------------------------------------
    def holds(self, who: Identity | None) -> bool:
        """Whether `who` holds the lease now (a holder quiet past the ttl does not, even before
        `expire()` runs)."""
        with self._lock:
            return self._holds(who, self.clock())

    def may_drive(self, who: Identity | None) -> bool:
        """The holder, or a participant token of the session the holder opened."""
        if who is None:
            return False
        with self._lock:
            now = self.clock()
            if self._holds(who, now):
                return True
            return (who.role == "participant" and who.session is not None and who.session == self.session
                    and self.holder is not None and not self._quiet(self.holder, now))

    def position(self, token_id: str) -> int | None:
        """1-based place in the queue, None when not queued."""
        with self._lock:
            for i, entry in enumerate(self.queue):
                if entry.token_id == token_id:
                    return i + 1
            return None

    def snapshot(self) -> dict:
        with self._lock:
            h = self.holder
            holder = None if h is None else {"token_id": h.token_id, "role": h.role, "site": h.site,
                                             "label": h.label, "since": h.since, "expires_at": h.seen + self.ttl_s}
            queue = [{"token_id": e.token_id, "role": e.role, "site": e.site, "label": e.label, "position": i + 1}
                     for i, e in enumerate(self.queue)]
            return {"holder": holder, "queue": queue, "session": self.session, "ttl_s": self.ttl_s}

    # ---- persistence -------------------------------------------------------------------------
    def to_record(self) -> dict:
        with self._lock:
            return {"holder": None if self.holder is None else self.holder.record(),
                    "queue": [e.record() for e in self.queue], "session": self.session}

    @classmethod
    def from_record(cls, record: dict | None, ttl_s: float, clock=time.time) -> "Lease":
        """The lease as persisted; who was quiet past the ttl meanwhile is dropped on the next
        `expire()` (seen times are wall-clock UTC). A malformed record gives an empty lease."""
        lease = cls(ttl_s, clock)
        if not record:
            return lease
        try:
            holder = record.get("holder")
            lease.holder = None if holder is None else _Entry(**holder)
            lease.queue = [_Entry(**e) for e in record.get("queue", [])]
            lease.session = record.get("session") if lease.holder is not None else None
        except (TypeError, AttributeError):
            return cls(ttl_s, clock)
        return lease

    # ---- internals (the lock is held) --------------------------------------------------------
    def _quiet(self, entry: _Entry, now: float) -> bool:
        return now >= entry.seen + self.ttl_s

    def _holds(self, who: Identity | None, now: float) -> bool:
        return (who is not None and self.holder is not None and self.holder.token_id == who.token_id
                and not self._quiet(self.holder, now))

    def _find(self, token_id: str) -> _Entry | None:
        if self.holder is not None and self.holder.token_id == token_id:
            return self.holder
        return next((e for e in self.queue if e.token_id == token_id), None)

    def _promote(self, now: float) -> None:
        """The first queued requester becomes the holder (fresh ttl); the open session closes."""
        self.holder = None
        self.session = None
        if self.queue:
            entry = self.queue.pop(0)
            entry.since = entry.seen = now
            self.holder = entry

    def _drop(self, token_id: str) -> bool:
        if self.holder is not None and self.holder.token_id == token_id:
            self._promote(self.clock())
            return True
        before = len(self.queue)
        self.queue = [e for e in self.queue if e.token_id != token_id]
        return len(self.queue) != before

    def _expire(self, now: float) -> bool:
        before = len(self.queue)
        self.queue = [e for e in self.queue if not self._quiet(e, now)]
        changed = len(self.queue) != before
        if self.holder is not None and self._quiet(self.holder, now):
            self._promote(now)
            changed = True
        return changed
