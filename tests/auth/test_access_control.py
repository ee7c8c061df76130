"""The facade: the lease persisted and published, kept across a restart, expiry and revocation on tick."""

from __future__ import annotations

import pytest

from server.auth import AccessControl, RunningTrial, Unauthorized, open_book
from server.auth.tokens import guess_key


@pytest.fixture
def access(tmp_path, clock):
    ac = AccessControl.open(tmp_path, lease_ttl_s=60.0, clock=clock)
    ac.published = []
    ac.on_lease_change = ac.published.append
    yield ac
    ac.close()


def test_two_sites_queue_release_and_expiry(access, clock):
    _, a = access.book.create("experimenter", "lab-a")
    _, b = access.book.create("experimenter", "lab-b")
    assert access.lease.request(a)["status"] == "granted"
    access.lease_changed()
    assert access.lease.request(b) == {"status": "queued", "position": 1}
    access.lease_changed()
    assert access.published[-1]["queue"][0]["site"] == "lab-b"
    access.lease.release(a)
    access.lease_changed()
    assert access.published[-1]["holder"]["token_id"] == b.token_id
    access.lease.request(a)
    access.lease_changed()
    clock.advance(60)  # both quiet
    assert access.lease.renew(a) is False  # expired on the way, without telling the facade ...
    access.tick()  # ... which publishes it anyway
    assert access.published[-1]["holder"] is None and access.published[-1]["queue"] == []
    assert access.store.load_lease()["holder"] is None


def test_expiry_on_tick_promotes_the_queued(access, clock):
    _, a = access.book.create("experimenter", "lab-a")
    _, b = access.book.create("experimenter", "lab-b")
    access.lease.request(a), access.lease.request(b)
    access.lease_changed()
    n = len(access.published)
    clock.advance(30)
    access.renew(b)
    access.tick()
    assert access.lease.holds(a)
    clock.advance(30)
    access.tick()
    assert access.lease.holds(b) and access.published[-1]["holder"]["token_id"] == b.token_id
    assert len(access.published) > n
    count = len(access.published)
    access.tick()
    assert len(access.published) == count  # nothing changed: nothing published


def test_renewals_are_published_only_when_the_expiry_moved_enough(access, clock):
    _, a = access.book.create("experimenter", "lab-a")
    access.lease.request(a)
    access.lease_changed()
    n = len(access.published)
    for _ in range(5):
        clock.advance(1)  # a request a second: 5 s < ttl/10
        assert access.renew(a)
    assert len(access.published) == n
    clock.advance(1)
    assert access.renew(a)
    assert len(access.published) == n + 1 and access.published[-1]["holder"]["expires_at"] == clock.now + 60
    _, b = access.book.create("experimenter", "lab-b")
    assert access.renew(b) is False


def test_the_lease_survives_a_restart(tmp_path, clock):
    first = AccessControl.open(tmp_path, clock=clock)
    env = first.book.add_ephemeral("E" * 40, "admin")
    _, a = first.book.create("experimenter", "lab-a")
    first.lease.request(env), first.lease.request(a)
    first.lease.open_session(env, "free-1234")
    first.lease_changed()
    snapshot = first.lease.snapshot()
    first.close()
    clock.advance(10)
    second = AccessControl.open(tmp_path, clock=clock)
    env_again = second.book.add_ephemeral("E" * 40, "admin")
    second.tick()
    assert second.lease.snapshot() == snapshot and second.lease.holds(env_again)
    second.close()


def test_a_restart_after_the_ttl_finds_the_lease_free(tmp_path, clock):
    first = AccessControl.open(tmp_path, clock=clock)
    _, a = first.book.create("experimenter", "lab-a")
    first.lease.request(a)
    first.lease_changed()
    first.close()
    clock.advance(61)
    second = AccessControl.open(tmp_path, clock=clock)
    assert second.lease.snapshot()["holder"] is None
    second.close()


def test_revocation_takes_the_token_out_of_the_lease(access, tmp_path, clock):
    _, a = access.book.create("experimenter", "lab-a")
    _, b = access.book.create("experimenter", "lab-b")
    access.lease.request(a), access.lease.request(b)
    access.lease_changed()
    assert access.revoke(a.token_id) is True
    assert access.lease.holds(b) and access.published[-1]["holder"]["token_id"] == b.token_id
    # revoked by another process (the CLI): out at the next tick
    cli_store, cli_book = open_book(tmp_path, clock)
    assert cli_book.revoke(b.token_id)
    access.tick()
    assert access.lease.snapshot()["holder"] is None and access.published[-1]["holder"] is None
    cli_store.close()


def test_a_failing_listener_does_not_undo_the_change(access, caplog):
    _, a = access.book.create("experimenter", "lab-a")

    def broken(snapshot):
        raise RuntimeError("hub gone")

    access.on_lease_change = broken
    access.lease.request(a)
    access.lease_changed()
    assert access.store.load_lease()["holder"]["token_id"] == a.token_id
    assert "on_lease_change failed" in caplog.text


def test_missing_token_is_not_a_failed_attempt(access):
    for _ in range(20):
        with pytest.raises(Unauthorized):
            access.authenticate(None, "10.1.1.1")
    assert access.throttle.blocked_for("10.1.1.1", 0) == 0.0


def test_a_valid_token_passes_while_a_guesser_at_its_address_is_throttled(access):
    """Failures are counted per token prefix (issue 35.5), never per address: the guesser waits, a
    valid token from the same address passes."""
    _, good = access.book.create("experimenter", "lab-a")
    secret, _ = access.book.create("observer")
    for _ in range(10):
        with pytest.raises(Unauthorized):
            access.authenticate("not-a-token-" + "x" * 20, "10.2.2.2")
    assert access.throttle.blocked_for(guess_key("token", "not-a-token-" + "x" * 20), access.clock()) > 0
    assert access.throttle.blocked_for("10.2.2.2", access.clock()) == 0.0
    assert access.authenticate(secret, "10.2.2.2").role == "observer"
    with pytest.raises(Unauthorized) as refused:  # the guesser still waits
        access.authenticate("not-a-token-" + "y" * 20, "10.2.2.2")
    assert refused.value.retry_after_s


def test_a_lab_that_takes_the_lease_back_mid_trial_gets_its_session_back_and_others_do_not(access, clock):
    _, a = access.book.create("experimenter", "lab-a")
    _, b = access.book.create("experimenter", "lab-b")
    access.running = lambda: RunningTrial("s-a", "lab-a")
    access.lease.request(a)
    assert access.follow_running() and access.published[-1]["session"] == "s-a"  # starting opened it
    access.lease.release(a)
    access.lease.request(b)
    access.lease_changed()
    assert access.published[-1]["session"] is None  # not for another lab
    access.lease.release(b)
    access.lease.request(a)  # Release → Request control, mid-trial
    access.lease_changed()
    assert access.published[-1]["session"] == "s-a"
    assert access.store.load_lease()["session"] == "s-a"


def test_tokens_revoked_here_or_by_another_process_are_announced(access, tmp_path, clock):
    told = []
    access.on_tokens_changed = lambda: told.append(True)
    _, a = access.book.create("observer")
    _, b = access.book.create("observer")
    assert access.revoke(a.token_id) and told == [True] and access.standing(a.token_id) == "revoked"
    access.tick()
    assert told == [True]  # nothing changed meanwhile: no store reads for the connections
    store, book = open_book(tmp_path)  # the CLI, on the same data directory
    assert book.revoke(b.token_id)
    store.close()
    access.tick()
    assert told == [True, True] and access.standing(b.token_id) == "revoked"
    _, c = access.book.create("observer", ttl_s=5)
    clock.advance(6)
    assert access.standing(c.token_id) == "expired"


def test_a_trial_that_starts_or_ends_publishes_the_lease_again(access, clock):
    _, b = access.book.create("experimenter", "lab-b")
    access.lease.request(b)
    access.lease_changed()
    running = [RunningTrial("s-a", "lab-a")]
    access.running = lambda: running[0]
    before = len(access.published)
    access.tick()
    assert len(access.published) == before + 1  # lab A's participant may drive now: clients re-check
    access.tick()
    assert len(access.published) == before + 1
    running[0] = None
    access.tick()
    assert len(access.published) == before + 2  # and may not any more
