"""Access control: identities and tokens, the control lease, the policy table, rate limits, audit.
The pure parts (identity, lease, policy, ratelimit) decide; the store keeps
DATA_DIR/access.sqlite and DATA_DIR/access.key; `AccessControl` is the one object a server holds
(app.state.access) and the shells (REST guard, /ws hub) ask."""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Callable

from server.auth.audit import Audit
from server.auth.identity import ROLES, Identity
from server.auth.lease import Lease
from server.auth.policy import POLICY, Rule, decide
from server.auth.ratelimit import FailureThrottle, TokenBucket
from server.auth.store import AccessStore, load_key
from server.auth.tokens import TokenBook

__all__ = ["AccessControl", "AccessStore", "Audit", "FailureThrottle", "Identity", "Lease", "POLICY", "ROLES",
           "Rule", "TokenBook", "TokenBucket", "Unauthorized", "decide", "open_book"]

log = logging.getLogger(__name__)

DB_NAME = "access.sqlite"
KEY_NAME = "access.key"


class Unauthorized(Exception):
    """No valid token (401), or too many failed attempts from this peer (429 with Retry-After)."""

    def __init__(self, message: str, retry_after_s: float | None = None):
        super().__init__(message)
        self.message = message
        self.retry_after_s = retry_after_s


def open_book(data_dir: str | Path, clock=time.time) -> tuple[AccessStore, TokenBook]:
    """The token book of a data directory without the lease (the CLI writes tokens while a server runs)."""
    data_dir = Path(data_dir)
    key = load_key(data_dir / KEY_NAME)
    store = AccessStore.open(data_dir / DB_NAME)
    return store, TokenBook(store, key, clock)


class AccessControl:
    def __init__(self, store: AccessStore, book: TokenBook, lease: Lease, audit: Audit,
                 throttle: FailureThrottle, clock=time.time):
        self.store = store
        self.book = book
        self.lease = lease
        self.audit = audit
        self.throttle = throttle
        self.clock = clock
        # wired to the hub's fan-out (Fanout.set_lease); called on the thread that changed the lease (REST
        # handlers run in a thread pool: the callee hands it to its event loop if it needs to)
        self.on_lease_change: Callable[[dict], None] = lambda snapshot: None
        self._published: dict = lease.to_record()  # the lease as last persisted and published
        self._data_version = store.data_version()

    @classmethod
    def open(cls, data_dir: str | Path, *, lease_ttl_s: float = 60.0, clock=time.time) -> "AccessControl":
        store, book = open_book(data_dir, clock)
        lease = Lease.from_record(store.load_lease(), lease_ttl_s, clock)
        access = cls(store, book, lease, Audit(store, clock), FailureThrottle(), clock)
        # tokens revoked meanwhile leave the lease on the first tick after a change, not here: the
        # environment's token (a lease holder before the restart too) is added after open()
        lease.expire()
        access.publish_if_changed()
        return access

    # ---- who is it ---------------------------------------------------------------------------
    def authenticate(self, secret: str | None, peer: str) -> Identity:
        """The identity of a valid token. Unauthorized without one; a peer that failed too often is
        refused (with retry_after_s) until its wait is over. A valid token passes even then: many
        clients share one address (the rig PC, a NAT), and one of them guessing must not lock the
        others out; a valid token does not clear the peer's failures either."""
        now = self.clock()
        who = self.book.verify(secret) if secret else None
        if who is not None:
            return who
        wait = self.throttle.blocked_for(peer, now)
        if wait > 0:
            raise Unauthorized("too many failed attempts; try again later", retry_after_s=wait)
        if not secret:
            raise Unauthorized("a token is needed (Authorization: Bearer TOKEN)")
        self.throttle.failed(peer, now)
        raise Unauthorized("the token is unknown, expired or revoked")

    def exchange(self, kind: str, code: str | None, peer: str, *, token_ttl_s: float | None) -> tuple[str, Identity]:
        """A login or join code for a new token (throttled per peer like `authenticate`)."""
        now = self.clock()
        wait = self.throttle.blocked_for(peer, now)
        if wait > 0:
            raise Unauthorized("too many failed attempts; try again later", retry_after_s=wait)
        got = self.book.redeem(kind, code, token_ttl_s=token_ttl_s) if code else None
        if got is None:
            self.throttle.failed(peer, now)
            raise Unauthorized(f"the {kind} code is unknown, expired or used")
        self.throttle.succeeded(peer)
        return got

    def revoke(self, token_id: str) -> bool:
        """Revokes a token and takes it out of the lease (holder or queue)."""
        done = self.book.revoke(token_id)
        if self.lease.drop(token_id):
            self.lease_changed()
        return done

    # ---- the lease ---------------------------------------------------------------------------
    def renew(self, who: Identity) -> bool:
        """A renewal on the holder's (or a queued requester's) activity; False when `who` is neither.
        Persisted and published only when the expiry moved by a tenth of the ttl: a busy console
        neither writes the database nor messages every viewer on each request."""
        renewed = self.lease.renew(who)
        self.publish_if_changed()
        return renewed

    def lease_changed(self) -> None:
        """Persist the lease and tell the hub (lease operations call it after each change)."""
        record = self.lease.to_record()
        self._published = record
        self.store.save_lease(record)
        try:
            self.on_lease_change(self.lease.snapshot())
        except Exception:  # a broken listener must not undo a lease change already persisted
            log.exception("on_lease_change failed")

    def publish_if_changed(self) -> bool:
        """`lease_changed()` when the lease differs from what was last published: another holder,
        queue or session (lease operations expire quiet entries on their way, so a change may come
        from a call that did not report one), or an expiry moved by a tenth of the ttl."""
        record = self.lease.to_record()
        if _shape(record) != _shape(self._published) or _seen_moved(record, self._published, self.lease.ttl_s / 10):
            self.lease_changed()
            return True
        return False

    def tick(self) -> None:
        """Periodic (the app calls it every 0.25 s): expiry, and tokens revoked by another process."""
        if self._external_change():
            self._drop_inactive()
        self.lease.expire()
        self.publish_if_changed()

    def _external_change(self) -> bool:
        version = self.store.data_version()
        changed, self._data_version = version != self._data_version, version
        return changed

    def _drop_inactive(self) -> bool:
        snap = self.lease.snapshot()
        ids = [e["token_id"] for e in ([snap["holder"]] if snap["holder"] else []) + snap["queue"]]
        dropped = False
        for token_id in ids:
            if not self.book.active(token_id):
                dropped |= self.lease.drop(token_id)
        return dropped

    def close(self) -> None:
        self.store.close()


def _shape(record: dict) -> tuple:
    """What a lease is, without the renewal times: holder (and since when), queue, open session."""
    holder = record["holder"]
    return ((holder["token_id"], holder["since"]) if holder else None,
            tuple(e["token_id"] for e in record["queue"]), record["session"])


def _seen_moved(record: dict, published: dict, by_s: float) -> bool:
    before = {e["token_id"]: e["seen"] for e in [published["holder"], *published["queue"]] if e}
    return any(e["seen"] - before.get(e["token_id"], float("-inf")) >= by_s
               for e in [record["holder"], *record["queue"]] if e)
