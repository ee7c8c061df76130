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
from server.auth.policy import POLICY, RunningTrial, Rule, decide
from server.auth.ratelimit import FailureThrottle, TokenBucket
from server.auth.store import AccessStore, load_key
from server.auth.tokens import TokenBook, guess_key

__all__ = ["AccessControl", "AccessStore", "Audit", "FailureThrottle", "Identity", "Lease", "POLICY", "ROLES",
           "Rule", "RunningTrial", "TokenBook", "TokenBucket", "Unauthorized", "decide", "open_book"]

log = logging.getLogger(__name__)

DB_NAME = "access.sqlite"
FREE_FAILURES = 5
KEY_NAME = "access.key"


class Unauthorized(Exception):
    """No valid token (401), or too many failed attempts with this token or code (429 with Retry-After)."""

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
        # wired to the hub (Hub.check_tokens): a token was revoked here or by another process (the CLI);
        # called on the event loop's thread (the revoke route and the tick run there)
        self.on_tokens_changed: Callable[[], None] = lambda: None
        # the trial being recorded now, if any (the app wires the experiment's): the rig is its lab's
        self.running: Callable[[], RunningTrial | None] = lambda: None
        self._published: dict = lease.to_record()  # the lease as last persisted and published
        self._data_version = store.data_version()
        self._running_seen: RunningTrial | None = None  # the running trial at the last tick

    @classmethod
    def open(cls, data_dir: str | Path, *, lease_ttl_s: float = 60.0, clock=time.time) -> "AccessControl":
        store, book = open_book(data_dir, clock)
        lease = Lease.from_record(store.load_lease(), lease_ttl_s, clock)
        # after FREE_FAILURES failures with one token's (or code's) prefix, the next attempt waits
        access = cls(store, book, lease, Audit(store, clock), FailureThrottle(free=FREE_FAILURES - 1), clock)
        # tokens revoked meanwhile leave the lease on the first tick after a change, not here: the
        # environment's token (a lease holder before the restart too) is added after open()
        lease.expire()
        access.publish_if_changed()
        return access

    # ---- who is it ---------------------------------------------------------------------------
    def authenticate(self, secret: str | None, peer: str = "") -> Identity:
        """The identity of a valid token; Unauthorized without one. Failed attempts are counted per
        token prefix (`guess_key`), never per peer address: after a few, an attempt with that prefix
        is not checked at all until its wait is over (retry_after_s), so guessing the rest of a
        known prefix is slowed, and a valid token of anyone else (on the rig PC, behind the same NAT)
        passes whatever others failed. `peer` only names the address in the log."""
        if not secret:
            raise Unauthorized("a token is needed (Authorization: Bearer TOKEN)")
        now = self.clock()
        key = guess_key("token", secret)
        self._not_blocked(key, now, "token", peer)
        who = self.book.verify(secret)
        if who is None:
            self.throttle.failed(key, now)
            raise Unauthorized("the token is unknown, expired or revoked")
        self.throttle.succeeded(key)
        return who

    def exchange(self, kind: str, code: str | None, peer: str, *, token_ttl_s: float | None) -> tuple[str, Identity]:
        """A login or join code for a new token (throttled per code prefix like `authenticate`)."""
        now = self.clock()
        key = guess_key(kind, code or "")
        self._not_blocked(key, now, f"{kind} code", peer)
        got = self.book.redeem(kind, code, token_ttl_s=token_ttl_s) if code else None
        if got is None:
            self.throttle.failed(key, now)
            raise Unauthorized(f"the {kind} code is unknown, expired or used")
        self.throttle.succeeded(key)
        return got

    def _not_blocked(self, key: str, now: float, what: str, peer: str) -> None:
        wait = self.throttle.blocked_for(key, now)
        if wait > 0:
            log.info("a %s beginning like earlier failed ones, from %s: not checked for %.1f s", what, peer or "?", wait)
            raise Unauthorized(f"too many failed attempts with this {what}; try again later", retry_after_s=wait)

    def standing(self, token_id: str) -> str | None:
        """None while the token may act; else "revoked" or "expired" (reads the database)."""
        return self.book.standing(token_id)

    def revoke(self, token_id: str) -> bool:
        """Revokes a token and takes it out of the lease (holder or queue)."""
        done = self.book.revoke(token_id)
        if self.lease.drop(token_id):
            self.lease_changed()
        if done:
            self._tokens_changed()
        return done

    def _tokens_changed(self) -> None:
        try:
            self.on_tokens_changed()
        except Exception:  # the revocation stands; the hub's next check closes the connections
            log.exception("on_tokens_changed failed")

    # ---- the lease ---------------------------------------------------------------------------
    def renew(self, who: Identity) -> bool:
        """A renewal on the holder's (or a queued requester's) activity; False when `who` is neither.
        Persisted and published only when the expiry moved by a tenth of the ttl: a busy console
        neither writes the database nor messages every viewer on each request."""
        renewed = self.lease.renew(who)
        self.publish_if_changed()
        return renewed

    def keepalive(self, who: Identity) -> None:
        """/ws activity that reached the rig (a tracker sample, a key, an answer): the lease holder's
        own, or a participant's of the session the holder opened, renews the holder's lease, so a
        streamed trial does not lose the lease while its console is quiet."""
        if self.lease.renew_by_activity(who):
            self.publish_if_changed()

    def follow_running(self) -> bool:
        """While a trial is recorded and the lease is with its lab, the open participant session is
        the trial's: starting a trial of S opens S, and a lab that takes the lease back mid-trial gets
        S back (its participant is never silently locked out of its own trial). True if it changed."""
        running = self.running()
        if running is None or not self.lease.open_for_running(running.session, running.site):
            return False
        self.lease_changed()
        return True

    def lease_changed(self) -> None:
        """Persist the lease and tell the hub (lease operations call it after each change)."""
        running = self.running()
        if running is not None:
            self.lease.open_for_running(running.session, running.site)
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
        """Periodic (the app calls it every 0.25 s): expiry, tokens revoked by another process, and a
        trial that started or ended (the lease is published again: the running trial's participant may
        drive whoever holds the lease, and no longer once it ends)."""
        if self._external_change():
            self._drop_inactive()
            self._tokens_changed()
        self.lease.expire()
        running = self.running()
        if running != self._running_seen:  # a trial started or ended: who may drive changed, tell every client
            self._running_seen = running
            self.lease_changed()
        elif not self.follow_running():
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
