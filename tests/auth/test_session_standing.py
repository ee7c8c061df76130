"""The I/O-free session's side of issues 35 and 34 (no server, no socket): a token that lapses while
connected ends the connection with the reason; /ws messages during another lab's running trial,
per message kind × caller; the lease renewed by activity; a participant told when its session
closes; a second connection of a participant session taking it; the failed-attempt throttle."""

from __future__ import annotations

import dataclasses

import msgpack
import pytest

from server.auth.lease import Lease
from server.auth.policy import POLICY, RunningTrial, decide
from server.auth.ratelimit import FailureThrottle
from server.hub.outbox import Close
from server.hub.session import KEEPALIVE_EVERY_NS, ServerInfo, Session, ToLoop
from server.ipc.records import TrackerGone
from server.wire import codec, messages
from tests.hub.access_fakes import ADMIN, EXP_A, EXP_B, OBSERVER, PART_1, PART_2, SECRET, Clock, gate

SERVER = ServerInfo("viestac/test", 1000, 60.0)
T0 = 5_000_000_000
TRACKER = {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 1]}
KEY = {"type": "input", "key": "ArrowUp", "action": "press"}
LAB_A_TRIAL = RunningTrial("s-1", "lab-a")


def frame(message: dict) -> bytes:
    return msgpack.packb(message)


def sent(session: Session) -> list:
    out = []
    while (item := session.outbox.next_frame()) is not None:
        out.append(item if isinstance(item, Close) else codec.decode(item))
    return out


def connect(who, lease: Lease, role: str = "participant", running=None, renewed=None) -> Session:
    g, _ = gate(lease)
    g = dataclasses.replace(g, running=lambda: running, keepalive=(renewed.append if renewed is not None
                                                                    else lambda who: None))
    s = Session(7, "msgpack", SERVER, T0, gate=g)
    s.receive(frame({"type": "hello", "v": 1, "role": role, "client": "pytest", "token": SECRET[who.token_id]}), T0)
    assert s.welcomed
    sent(s)
    return s


def lease_frames(lease: Lease) -> dict:
    return {fmt: codec.encode(messages.lease(lease.snapshot()), fmt) for fmt in codec.FORMATS}


def held_by(who, session: str | None = None) -> Lease:
    lease = Lease(60.0, clock=Clock())
    assert lease.request(who)["status"] == "granted"
    if session is not None:
        lease.open_session(who, session)
    return lease


@pytest.mark.parametrize("why, text", [("revoked", "your access was revoked"),
                                       ("expired", "your access expired: ask for a new link")])
def test_a_lapsed_token_ends_the_connection_with_its_reason_and_nothing_after_is_applied(why, text):
    s = connect(PART_1, held_by(EXP_A, "s-1"))
    assert s.receive(frame(TRACKER), T0 + 1)  # it drives
    assert s.withdraw(why) == [ToLoop(TrackerGone(7))]  # the HIP goes home at once
    error, close = sent(s)
    assert (error["code"], error["message"]) == ("unauthorized", text)
    assert close == Close(1008, why)
    assert s.receive(frame(TRACKER), T0 + 2) == [] and s.receive(frame(KEY), T0 + 3) == []
    assert sent(s) == [] and s.withdraw(why) == []


# who x message kind during lab A's recorded trial of session s-1 (lab B holds the lease, or lab A)
CASES = [  # (who sends, lease holder, kind, allowed)
    (EXP_B, EXP_B, "tracker", False), (EXP_B, EXP_B, "input", False), (EXP_B, EXP_B, "input:operator", False),
    (PART_2, EXP_B, "tracker", False),
    (PART_1, EXP_B, "tracker", True), (PART_1, EXP_B, "input", True),  # its own trial: whoever holds the lease
    (EXP_A, EXP_A, "tracker", True), (EXP_A, EXP_A, "input:operator", True),
    (ADMIN, ADMIN, "input:operator", True),  # the rig's owner counts as every lab
    (OBSERVER, EXP_B, "tracker", False),
]


@pytest.mark.parametrize("who, holder, kind, allowed", CASES, ids=lambda v: getattr(v, "token_id", str(v)))
def test_during_another_labs_trial_only_its_own_lab_and_session_act(who, holder, kind, allowed):
    lease = held_by(holder, "s-2" if holder is EXP_B else None)
    s = connect(who, lease, "operator" if who.role != "participant" else "participant", running=LAB_A_TRIAL)
    refusal = s.refusal(kind)
    assert (refusal is None) == allowed, refusal
    if not allowed and who.role != "observer":
        verdict = decide(POLICY[f"ws:{kind}"], who, lease, LAB_A_TRIAL)
        assert verdict is not None and refusal == verdict[1]
        if verdict[0] == 409:
            assert "lab lab-a" in refusal


def test_activity_renews_the_lease_at_most_once_a_second():
    renewed: list = []
    s = connect(PART_1, held_by(EXP_A, "s-1"), renewed=renewed)
    for i in range(50):  # 50 samples in 0.5 s
        s.receive(frame({**TRACKER, "seq": i + 1}), T0 + i * 10_000_000)
    assert renewed == [PART_1]
    s.receive(frame({**TRACKER, "seq": 99}), T0 + KEEPALIVE_EVERY_NS + 1)
    assert renewed == [PART_1, PART_1]


def test_the_lease_renewed_by_the_holders_participant_not_by_a_stranger():
    clock = Clock()
    lease = Lease(10.0, clock=clock)
    lease.request(EXP_A)
    lease.open_session(EXP_A, "s-1")
    clock.t += 9.0
    assert not lease.renew_by_activity(PART_2) and lease.renew_by_activity(PART_1)
    clock.t += 9.0  # 18 s after the request, 9 s after the participant's activity
    assert lease.holds(EXP_A)
    assert not lease.renew_by_activity(EXP_B)


def test_a_participant_is_told_when_its_session_closes_and_not_again():
    lease = held_by(EXP_A, "s-1")
    s = connect(PART_1, lease)
    lease.release(EXP_A)
    s.set_lease(lease_frames(lease))
    got = sent(s)
    assert [m["type"] for m in got] == ["lease", "error"] and got[1]["code"] == "session_closed"
    assert "wait" in got[1]["message"]
    s.set_lease(lease_frames(lease))
    assert [m["type"] for m in sent(s)] == ["lease"]  # once per closing


def test_the_running_trials_session_follows_its_lab_back_into_the_lease():
    lease = held_by(EXP_A, "s-1")
    lease.release(EXP_A)
    lease.request(EXP_B)
    assert not lease.open_for_running("s-1", "lab-a") and lease.session is None  # another lab: not opened
    lease.release(EXP_B)
    lease.request(EXP_A)
    assert lease.session is None and lease.open_for_running("s-1", "lab-a") and lease.session == "s-1"


def test_a_second_connection_of_a_session_takes_it():
    lease = held_by(EXP_A, "s-1")
    older = connect(PART_1, lease)
    older.receive(frame(TRACKER), T0 + 1)
    assert older.withdraw("taken", 8) == [ToLoop(TrackerGone(7))]
    (told,) = sent(older)
    assert told["code"] == "session_taken" and "another tab" in told["message"]
    assert not older.closing and older.info()["replaced_by"] == 8 and older.info()["session"] == "s-1"
    assert older.receive(frame(TRACKER), T0 + 2) == []
    assert sent(older)[0]["code"] == "forbidden"


def test_the_throttle_keeps_a_blocked_key_when_fresh_guesses_flood_it():
    t = FailureThrottle(free=1, base_s=60.0, max_keys=3)
    t.failed("known-prefix", 0.0), t.failed("known-prefix", 0.0)
    for i in range(100):  # fresh guesses, each failing once (free): they push each other out, not it
        t.failed(f"guess-{i}", 1.0)
    assert t.blocked_for("known-prefix", 1.0) == pytest.approx(59.0)


def test_when_its_trial_ends_under_another_labs_lease_the_participant_lets_go_and_is_told():
    lease = held_by(EXP_B)
    running = [LAB_A_TRIAL]
    g, _ = gate(lease)
    g = dataclasses.replace(g, running=lambda: running[0])
    s = Session(7, "msgpack", SERVER, T0, gate=g)
    s.receive(frame({"type": "hello", "v": 1, "role": "participant", "client": "pytest",
                     "token": SECRET[PART_1.token_id]}), T0)
    sent(s)
    assert s.receive(frame(TRACKER), T0 + 1)  # its own trial: it drives under lab B's lease
    running[0] = None  # the trial ended; the lease is published again (AccessControl.tick)
    assert s.set_lease(lease_frames(lease)) == [ToLoop(TrackerGone(7))]
    assert [m.get("code") for m in sent(s)] == [None, "session_closed"]
