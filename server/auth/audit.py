"""The audit log: every control action (who, what, on what, when, with what result)."""

from __future__ import annotations

import time

from server.auth.identity import Identity
from server.auth.store import AccessStore


class Audit:
    def __init__(self, store: AccessStore, clock=time.time):
        self.store = store
        self.clock = clock

    def record(self, who: Identity | None, action: str, target: str, result: str, *, session_id: str | None = None,
               detail=None, site: str | None = None) -> None:
        """One row. `site`: the site the action concerns when it is not the actor's (an admin acting on
        a lab's session), so that lab sees it; default: the actor's site."""
        self.store.add_audit({"utc": self.clock(), "token_id": who.token_id if who else None,
                              "role": who.role if who else None,
                              "site": site if site is not None else (who.site if who else None),
                              "action": action, "target": target, "result": result, "session_id": session_id,
                              "detail": detail})

    def rows(self, *, site: str | None = None, session_id: str | None = None, limit: int = 200) -> list[dict]:
        """{id, utc, token_id, role, site, action, target, result, session_id, detail}, oldest first
        (the newest `limit`). site None: every site (the admin's view)."""
        return self.store.audit_rows(site=site, session_id=session_id, limit=limit)
