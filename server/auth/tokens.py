"""Tokens and single-use codes: random secrets, stored only as HMAC-SHA256(server key, secret).

A token is `secrets.token_urlsafe(32)` (256 bits; never starting with "-", see new_secret): far
beyond guessing, so a keyed hash from the standard library is enough and a slow KDF would only
slow every request (a KDF protects low-entropy passwords). The key lives outside the database
(store.load_key), so a copied access.sqlite alone does not let anyone test guesses offline. Codes
(login, join) are the same, single use, short-lived.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets
import threading
import time

from server.auth.identity import Identity, check_grant
from server.auth.store import AccessStore

MAX_SECRET = 200  # longer input is refused before hashing (hello.token is at most 200 characters)
MIN_EPHEMERAL = 16  # an env token shorter than this is refused: it must not be guessable
CODE_KINDS = {"login": "admin", "join": "participant"}  # kind -> the role of the token it is exchanged for
# The characters of a presented secret that name its failed-attempt key (72 bits: one key per real
# secret): a guesser who knows how a secret begins (read over a shoulder, half pasted) and tries the
# rest is slowed, a client retrying its revoked token is slowed, and nobody else is.
GUESS_PREFIX = 12


def new_secret(nbytes: int) -> str:
    """`secrets.token_urlsafe(nbytes)` that does not start with "-": pasted after `--token`, such
    a secret reads as an option and the command stops with a usage error (1 secret in 64).
    Drawing again leaves out 1/64 of the values: 0.02 bits of 256."""
    while True:
        secret = secrets.token_urlsafe(nbytes)
        if secret[0] != "-":
            return secret


def guess_key(kind: str, secret: str) -> str:
    """The failed-attempt throttle's key of a presented token or code (server/auth/ratelimit.py):
    its kind and a hash of its first GUESS_PREFIX characters; never the peer's address, so one
    guesser behind the rig PC's or a NAT's address locks nobody else out."""
    prefix = secret[:GUESS_PREFIX].encode("utf-8", "replace")
    return f"{kind}:{hashlib.sha256(prefix).hexdigest()[:16]}"


class TokenBook:
    """Tokens and codes; the clock (UTC seconds) is injected."""

    def __init__(self, store: AccessStore, key: bytes, clock=time.time):
        if len(key) < 32:
            raise ValueError("the server key must be at least 32 bytes")
        self.store = store
        self._key = key
        self.clock = clock
        self._lock = threading.Lock()
        self._ephemeral: dict[str, tuple[Identity, float]] = {}  # digest -> (identity, added at)

    def _digest(self, secret: str) -> str:
        return hmac.new(self._key, secret.encode("utf-8"), hashlib.sha256).hexdigest()

    # ---- tokens ------------------------------------------------------------------------------
    def create(self, role: str, site: str | None = None, *, session: str | None = None, label: str = "",
               ttl_s: float | None = None, created_by: str | None = None) -> tuple[str, Identity]:
        """A new token: (the secret, shown once, and its identity). ttl_s None: it never expires."""
        check_grant(role, site, session, label)
        if ttl_s is not None and not ttl_s > 0:
            raise ValueError("ttl_s must be positive (or None: no expiry)")
        now = self.clock()
        expires_at = None if ttl_s is None else now + float(ttl_s)
        secret = new_secret(32)
        digest = self._digest(secret)
        while True:  # a token id collision (8 hex digits) is rare: draw again
            token_id = secrets.token_hex(4)
            row = {"token_id": token_id, "digest": digest, "role": role, "site": site, "session": session,
                   "label": label, "created_at": now, "expires_at": expires_at, "revoked_at": None,
                   "created_by": created_by}
            if self._ephemeral_id_taken(token_id):
                continue
            if self.store.insert_token(row):
                return secret, _identity(row)

    def _ephemeral_id_taken(self, token_id: str) -> bool:
        with self._lock:
            return any(ident.token_id == token_id for ident, _ in self._ephemeral.values())

    def add_ephemeral(self, secret: str, role: str, *, site: str | None = None, label: str = "env") -> Identity:
        """A token held in memory only (VIESTAC_ADMIN_TOKEN): never written anywhere. Its id is
        derived from the secret and the server key, so it is the same after a restart and a lease
        it held is still its own."""
        if not isinstance(secret, str) or not MIN_EPHEMERAL <= len(secret) <= MAX_SECRET or not secret.isascii():
            raise ValueError(f"a token given in the environment must be {MIN_EPHEMERAL}-{MAX_SECRET} ASCII characters")
        check_grant(role, site, None, label)
        digest = self._digest(secret)
        token_id = hmac.new(self._key, b"ephemeral-id\0" + digest.encode(), hashlib.sha256).hexdigest()[:8]
        ident = Identity(token_id, role, site, None, label, None)
        with self._lock:
            self._ephemeral[digest] = (ident, self.clock())
        return ident

    def verify(self, secret: str | None) -> Identity | None:
        """The identity of a valid token; None when it is missing, malformed, unknown, expired or
        revoked. Reads the database each time: a token revoked by the CLI stops working at once."""
        if not isinstance(secret, str) or not 0 < len(secret) <= MAX_SECRET or not secret.isascii():
            return None
        digest = self._digest(secret)
        with self._lock:
            held = self._ephemeral.get(digest)
        if held is not None:
            return held[0]
        row = self.store.token_by_digest(digest)
        if row is None or row["revoked_at"] is not None or _expired(row["expires_at"], self.clock()):
            return None
        return _identity(row)

    def active(self, token_id: str) -> bool:
        """Whether a token of this id may still act (not revoked, not expired)."""
        return self.standing(token_id) is None

    def standing(self, token_id: str) -> str | None:
        """None while a token of this id may act; else why not: "revoked" (or unknown) or "expired"."""
        with self._lock:
            if any(ident.token_id == token_id for ident, _ in self._ephemeral.values()):
                return None
        row = self.store.token(token_id)
        if row is None or row["revoked_at"] is not None:
            return "revoked"
        return "expired" if _expired(row["expires_at"], self.clock()) else None

    def revoke(self, token_id: str) -> bool:
        """False when no active token has this id (unknown or revoked already)."""
        with self._lock:
            for digest, (ident, _) in list(self._ephemeral.items()):
                if ident.token_id == token_id:
                    del self._ephemeral[digest]
                    return True
        return self.store.revoke_token(token_id, self.clock())

    def list(self) -> list[dict]:
        """Every token, revoked and expired ones too: identity fields + created_at, revoked_at,
        created_by, `active` and `persistent` (False: held in memory, from the environment)."""
        now = self.clock()
        with self._lock:
            out = [{**ident.to_dict(), "created_at": added, "revoked_at": None, "created_by": None,
                    "active": True, "persistent": False} for ident, added in self._ephemeral.values()]
        for row in self.store.tokens():
            active = row["revoked_at"] is None and not _expired(row["expires_at"], now)
            out.append({**_identity(row).to_dict(), "created_at": row["created_at"], "revoked_at": row["revoked_at"],
                        "created_by": row["created_by"], "active": active, "persistent": True})
        return out

    # ---- single-use codes --------------------------------------------------------------------
    def create_code(self, kind: str, *, role: str, site: str | None = None, session: str | None = None,
                    ttl_s: float, created_by: str | None = None) -> str:
        """A single-use code (login: for an admin token; join: for a participant token of one
        session). Only its hash is stored; it travels in a URL fragment and is exchanged at once."""
        if CODE_KINDS.get(kind) is None:
            raise ValueError(f"unknown code kind {kind!r}; expected login or join")
        if role != CODE_KINDS[kind]:
            raise ValueError(f"a {kind} code gives a {CODE_KINDS[kind]} token, not {role}")
        check_grant(role, site, session, "")
        if not ttl_s > 0:
            raise ValueError("ttl_s must be positive")
        now = self.clock()
        code = new_secret(24)
        self.store.insert_code({"digest": self._digest(code), "kind": kind, "role": role, "site": site,
                                "session": session, "created_at": now, "expires_at": now + float(ttl_s),
                                "used_at": None, "created_by": created_by})
        return code

    def redeem(self, kind: str, code: str, *, token_ttl_s: float | None) -> tuple[str, Identity] | None:
        """Exchanges a valid unused code for a new token (the code is spent); None when the code is
        unknown, of another kind, expired, used or malformed."""
        if kind not in CODE_KINDS or not isinstance(code, str) or not 0 < len(code) <= MAX_SECRET \
                or not code.isascii():
            return None
        row = self.store.use_code(self._digest(code), kind, self.clock())
        if row is None:
            return None
        return self.create(row["role"], row["site"], session=row["session"], label=f"{kind} code",
                           ttl_s=token_ttl_s, created_by=row["created_by"])


def _expired(expires_at: float | None, now: float) -> bool:
    return expires_at is not None and now >= expires_at


def _identity(row: dict) -> Identity:
    return Identity(row["token_id"], row["role"], row["site"], row["session"], row["label"] or "", row["expires_at"])
