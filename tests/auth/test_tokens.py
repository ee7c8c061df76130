"""Tokens and single-use codes: HMAC-only storage, expiry, revocation across connections, codes."""

from __future__ import annotations

import os
import stat

import pytest

from server.auth import AccessControl, open_book
from server.auth.store import load_key
from server.auth.tokens import TokenBook


@pytest.fixture
def book(tmp_path, clock):
    store, book = open_book(tmp_path, clock)
    yield book
    store.close()


def test_a_token_verifies_to_its_identity(book):
    secret, ident = book.create("experimenter", "lab-a", label="Ada")
    assert len(ident.token_id) == 8 and int(ident.token_id, 16) >= 0
    assert book.verify(secret) == ident
    assert ident.to_dict() == {"token_id": ident.token_id, "role": "experimenter", "site": "lab-a", "session": None,
                               "label": "Ada", "expires_at": None}


@pytest.mark.parametrize("bad", [None, "", "x", "é" * 10, "a" * 201, 42])
def test_malformed_or_unknown_secrets_verify_to_none(book, bad):
    book.create("admin")
    assert book.verify(bad) is None


def test_only_the_hmac_is_stored(tmp_path, book):
    secret, ident = book.create("admin")
    code = book.create_code("login", role="admin", ttl_s=60)
    book.store.close()  # flush the WAL into the file
    raw = b"".join(p.read_bytes() for p in tmp_path.iterdir() if p.name.startswith("access.sqlite"))
    assert secret.encode() not in raw and code.encode() not in raw
    assert ident.token_id.encode() in raw  # the file is readable: the test looks at the right bytes
    key = (tmp_path / "access.key").read_bytes()
    assert len(key) == 32 and key not in raw
    assert stat.S_IMODE(os.stat(tmp_path / "access.key").st_mode) == 0o600
    assert stat.S_IMODE(os.stat(tmp_path / "access.sqlite").st_mode) == 0o600


def test_another_key_does_not_verify_the_token(tmp_path, clock):
    store, book = open_book(tmp_path, clock)
    secret, _ = book.create("admin")
    assert TokenBook(store, b"k" * 32, clock).verify(secret) is None


def test_the_key_is_kept_across_opens(tmp_path):
    assert load_key(tmp_path / "k") == load_key(tmp_path / "k")
    (tmp_path / "bad").write_bytes(b"short")
    with pytest.raises(ValueError):
        load_key(tmp_path / "bad")


def test_expiry(book, clock):
    secret, ident = book.create("observer", ttl_s=3600)
    assert ident.expires_at == clock.now + 3600
    clock.advance(3599)
    assert book.verify(secret) == ident
    clock.advance(1)
    assert book.verify(secret) is None
    assert [t["active"] for t in book.list()] == [False]


def test_revocation_is_seen_by_a_second_store_on_the_same_file(tmp_path, clock):
    server_store, server_book = open_book(tmp_path, clock)
    cli_store, cli_book = open_book(tmp_path, clock)
    secret, ident = cli_book.create("experimenter", "lab-b")
    assert server_book.verify(secret) == ident  # created by the CLI, valid at once in the server
    assert cli_book.revoke(ident.token_id) is True
    assert server_book.verify(secret) is None
    assert cli_book.revoke(ident.token_id) is False  # already revoked
    assert cli_book.revoke("00000000") is False
    row = next(t for t in server_book.list() if t["token_id"] == ident.token_id)
    assert row["revoked_at"] == clock.now and row["active"] is False
    server_store.close()
    cli_store.close()


@pytest.mark.parametrize("role,site,session", [
    ("root", None, None), ("admin", "lab-a", None), ("experimenter", None, None),
    ("participant", "lab-a", None), ("observer", None, "s1"), ("experimenter", "lab a", None),
])
def test_grants_that_make_no_sense_are_refused(book, role, site, session):
    with pytest.raises(ValueError):
        book.create(role, site, session=session)


def test_ephemeral_token_is_memory_only_with_a_stable_id(tmp_path, clock):
    store, book = open_book(tmp_path, clock)
    ident = book.add_ephemeral("s" * 32, "admin")
    assert book.verify("s" * 32) == ident and ident.label == "env"
    assert store.tokens() == []
    assert [t["persistent"] for t in book.list()] == [False]
    again = TokenBook(store, load_key(tmp_path / "access.key"), clock).add_ephemeral("s" * 32, "admin")
    assert again.token_id == ident.token_id
    with pytest.raises(ValueError):
        book.add_ephemeral("short", "admin")
    assert book.revoke(ident.token_id) is True
    assert book.verify("s" * 32) is None


def test_codes_are_single_use_and_short_lived(book, clock):
    code = book.create_code("join", role="participant", site="lab-a", session="s-7", ttl_s=900, created_by="abcd0123")
    assert book.redeem("login", code, token_ttl_s=None) is None  # wrong kind: not spent
    secret, ident = book.redeem("join", code, token_ttl_s=3600)
    assert (ident.role, ident.site, ident.session) == ("participant", "lab-a", "s-7")
    assert book.verify(secret) == ident and ident.expires_at == clock.now + 3600
    assert book.redeem("join", code, token_ttl_s=3600) is None  # used
    late = book.create_code("login", role="admin", ttl_s=3600)
    clock.advance(3600)
    assert book.redeem("login", late, token_ttl_s=None) is None
    assert book.redeem("join", None, token_ttl_s=None) is None
    with pytest.raises(ValueError):
        book.create_code("login", role="experimenter", site="lab-a", ttl_s=60)


def test_authenticate_throttles_failures_per_peer(tmp_path, clock):
    access = AccessControl.open(tmp_path, clock=clock)
    secret, ident = access.book.create("observer")
    from server.auth import Unauthorized
    for _ in range(5):
        with pytest.raises(Unauthorized) as exc:
            access.authenticate("wrong", "10.0.0.9")
        assert exc.value.retry_after_s is None
    with pytest.raises(Unauthorized):
        access.authenticate("wrong", "10.0.0.9")  # the sixth failure blocks the peer
    with pytest.raises(Unauthorized) as exc:
        access.authenticate("wrong", "10.0.0.9")  # the blocked peer's next guess waits
    assert exc.value.retry_after_s == pytest.approx(1.0)
    assert access.authenticate(secret, "10.0.0.9") == ident  # a good token is not locked out
    clock.advance(1.0)
    with pytest.raises(Unauthorized) as exc:
        access.authenticate("wrong", "10.0.0.9")
    assert exc.value.retry_after_s is None  # the wait is over: this guess counts (and blocks again)
    access.close()


def test_a_code_is_spent_once_by_racing_redeemers_in_two_processes_views(tmp_path, clock):
    """Two connections (a server and a second process) redeem one code at once: one wins."""
    from concurrent.futures import ThreadPoolExecutor

    stores_books = [open_book(tmp_path, clock) for _ in range(4)]
    code = stores_books[0][1].create_code("join", role="participant", session="s1", ttl_s=60)
    with ThreadPoolExecutor(4) as pool:
        results = list(pool.map(lambda sb: sb[1].redeem("join", code, token_ttl_s=60), stores_books * 3))
    assert sum(r is not None for r in results) == 1
    for store, _ in stores_books:
        store.close()


def test_no_secret_starts_with_a_dash_so_it_never_reads_as_a_command_line_option(book, monkeypatch):
    import secrets

    draws = iter(["-starts-like-an-option", "_fine", "-again", "fine-too"])
    monkeypatch.setattr(secrets, "token_urlsafe", lambda nbytes: next(draws))
    secret, ident = book.create("admin")
    assert secret == "_fine" and book.verify(secret) == ident
    assert book.create_code("login", role="admin", ttl_s=60) == "fine-too"
