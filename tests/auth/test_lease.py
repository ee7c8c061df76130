"""The control lease: grant, queue, renew, release, expiry, hand-over, force release, restart."""

from __future__ import annotations

import pytest

from server.auth.identity import Identity
from server.auth.lease import Lease

A = Identity("aaaa0001", "experimenter", "lab-a", label="A")
B = Identity("bbbb0002", "experimenter", "lab-b", label="B")
C = Identity("cccc0003", "admin")
P = Identity("dddd0004", "participant", "lab-a", session="s1")
OBS = Identity("eeee0005", "observer")


@pytest.fixture
def lease(clock):
    return Lease(60.0, clock)


def test_first_is_granted_second_queued(lease):
    assert lease.request(A) == {"status": "granted", "position": None}
    assert lease.request(B) == {"status": "queued", "position": 1}
    assert lease.request(C) == {"status": "queued", "position": 2}
    assert lease.request(A) == {"status": "held", "position": None}
    assert lease.request(B) == {"status": "queued", "position": 1}
    assert lease.holds(A) and not lease.holds(B) and not lease.holds(None)
    snap = lease.snapshot()
    assert snap["holder"]["token_id"] == A.token_id and [q["token_id"] for q in snap["queue"]] == ["bbbb0002", "cccc0003"]


def test_only_staff_may_request(lease):
    for who in (P, OBS):
        with pytest.raises(PermissionError):
            lease.request(who)


def test_release_passes_the_lease_on(lease):
    lease.request(A), lease.request(B)
    assert lease.release(B) is True and lease.snapshot()["queue"] == []  # leaves the queue
    lease.request(B)
    assert lease.release(A) is True
    assert lease.holds(B) and lease.snapshot()["queue"] == []
    assert lease.release(A) is False


def test_the_quiet_holder_expires_and_the_next_gets_it(lease, clock):
    lease.request(A), lease.request(B)
    clock.advance(30)
    assert lease.renew(B)
    clock.advance(30)  # A quiet for 60 s
    assert not lease.holds(A)  # even before expire() runs
    assert lease.expire() is True
    assert lease.holds(B) and lease.snapshot()["holder"]["expires_at"] == clock.now + 60
    assert lease.expire() is False


def test_a_quiet_queued_requester_leaves_the_queue(lease, clock):
    lease.request(A), lease.request(B)
    clock.advance(40)
    lease.renew(A)
    clock.advance(20)
    assert lease.expire() is True
    assert lease.holds(A) and lease.snapshot()["queue"] == []
    assert lease.renew(B) is False


def test_renewal_keeps_the_lease(lease, clock):
    lease.request(A)
    for _ in range(5):
        clock.advance(59)
        assert lease.renew(A)
    assert lease.holds(A) and lease.expire() is False


def test_hand_over_and_force_release(lease):
    lease.request(A), lease.request(B), lease.request(C)
    assert lease.hand_over(B, C.token_id) is False  # not the holder
    with pytest.raises(ValueError):
        lease.hand_over(A, "nobody00")
    assert lease.hand_over(A, C.token_id) is True
    assert lease.holds(C) and [q["token_id"] for q in lease.snapshot()["queue"]] == [B.token_id]
    assert lease.force_release() is True and lease.holds(B)
    assert lease.force_release() is True and lease.snapshot()["holder"] is None
    assert lease.force_release() is False


def test_a_participant_drives_only_in_the_session_the_holder_opened(lease):
    assert not lease.may_drive(P)
    lease.request(A)
    assert lease.may_drive(A) and not lease.may_drive(B) and not lease.may_drive(None)
    with pytest.raises(PermissionError):
        lease.open_session(B, "s1")
    assert not lease.may_drive(P)
    lease.open_session(A, "s1")
    assert lease.may_drive(P)
    assert not lease.may_drive(Identity("ffff0006", "participant", "lab-a", session="s2"))
    lease.release(A)  # a new holder (or none) closes the session
    assert not lease.may_drive(P) and lease.snapshot()["session"] is None


def test_drop_removes_a_revoked_token(lease):
    lease.request(A), lease.request(B)
    assert lease.drop(A.token_id) and lease.holds(B)
    assert lease.drop(A.token_id) is False


def test_survives_a_restart(lease, clock):
    lease.request(A), lease.request(B)
    lease.open_session(A, "s1")
    record = lease.to_record()
    clock.advance(30)
    again = Lease.from_record(record, 60.0, clock)
    assert again.snapshot() == lease.snapshot()
    assert again.holds(A) and again.may_drive(P)
    clock.advance(30)  # down too long: expiry counts from the last renewal before the restart
    assert again.expire() and again.snapshot()["holder"] is None  # B was quiet too


@pytest.mark.parametrize("record", [None, {}, {"holder": {"token_id": 1}}, {"holder": None, "queue": [{"x": 1}]}])
def test_a_malformed_record_gives_an_empty_lease(clock, record):
    assert Lease.from_record(record, 60.0, clock).snapshot() == {"holder": None, "queue": [], "session": None,
                                                                 "ttl_s": 60.0}
