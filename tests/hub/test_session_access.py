"""Access control in the I/O-free session (issue 19): the token in `hello`, the role granted for
the one asked, every client message type checked against the declared policy
(server.auth.policy.POLICY) and the control lease, the `lease` message, and a client that loses
the right to drive leaving the HIP. No server, no socket."""

from __future__ import annotations

import msgpack
import pytest

from server.auth.identity import Identity
from server.auth.lease import Lease
from server.auth.policy import POLICY, decide
from server.hub.input_budget import FORBIDDEN_TRACKER_ERROR_EVERY_NS, INPUT_BURST
from server.hub.outbox import Close
from server.hub.session import HELLO_TIMEOUT_NS, ActuatorsOffered, Command, Gate, ParticipantAnswer, ServerInfo, Session, ToLoop
from server.wire import codec, messages
from server.wire.schema import CLIENT_MESSAGE_NAMES
from tests.hub.access_fakes import (ADMIN, EXP_A, EXP_B, OBSERVER, PART_1, PART_2, SECRET, Clock, gate)
from server.ipc.records import TrackerGone

SERVER = ServerInfo("viestac/test", 1000, 60.0)
T0 = 5_000_000_000
SCENE = {fmt: codec.encode({"type": "scene", "v": 1, "hash": "aaaa", "scene": {}}, fmt) for fmt in codec.FORMATS}
TRACKER = {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 1]}
KEY = {"type": "input", "key": "ArrowUp", "action": "press"}
ANSWER = {"type": "answer", "seq": 3, "question": "roughness", "value": 5}
ACTUATORS = {"type": "actuators", "actuators": [["xr", "right"]]}
# one valid message of each client type but hello
SAMPLE = {"tracker": TRACKER, "input": KEY, "answer": ANSWER, "actuators": ACTUATORS}
DRIVING = ("input", "tracker")  # the kinds that drive the rig (the lease rule); `answer` and `actuators` have their own


def frame(message: dict) -> bytes:
    return msgpack.packb(message)


def hello(role: str = "participant", token: str | None = None) -> bytes:
    body = {"type": "hello", "v": 1, "role": role, "client": "pytest"}
    if token is not None:
        body["token"] = token
    return frame(body)


def sent(session: Session) -> list:
    out = []
    while (item := session.outbox.next_frame()) is not None:
        out.append(item if isinstance(item, Close) else codec.decode(item))
    return out


def kinds(items: list) -> list:
    return [m if isinstance(m, Close) else m["type"] if m["type"] != "error" else m["code"] for m in items]


def connect(who, role: str = "participant", lease: Lease | None = None, **kw) -> tuple[Session, Lease]:
    g, lease = gate(lease, **kw)
    s = Session(7, "msgpack", SERVER, T0, gate=g)
    s.set_scene("aaaa", SCENE)
    s.receive(hello(role, SECRET[who.token_id]), T0)
    return s, lease


def lease_frames(lease: Lease) -> dict:
    return {fmt: codec.encode(messages.lease(lease.snapshot()), fmt) for fmt in codec.FORMATS}


# ---- the token ------------------------------------------------------------------------------------
@pytest.mark.parametrize("token", [None, "", "not-a-token", "admin-secret "])
def test_a_hello_without_a_valid_token_is_refused_and_the_connection_closes(token):
    g, _ = gate()
    s = Session(7, "msgpack", SERVER, T0, gate=g)
    s.set_scene("aaaa", SCENE)
    assert s.receive(hello("operator", token), T0 + 1) == []
    out = sent(s)
    assert kinds(out) == ["unauthorized", Close(1008)]  # no welcome, no scene
    assert s.closing and not s.welcomed and s.identity is None
    s.offer_state(b"x", "aaaa")
    assert s.receive(frame(TRACKER), T0 + 2) == [] and sent(s) == []


def test_the_token_never_shows_in_an_error_or_a_repr():
    g, _ = gate()
    s = Session(7, "msgpack", SERVER, T0, gate=g)
    s.receive(hello("operator", "a-guessed-secret-123"), T0)
    assert "a-guessed-secret-123" not in repr(sent(s))
    parsed = messages.parse_client_message(msgpack.unpackb(hello("operator", "a-guessed-secret-123")))
    assert parsed.token == "a-guessed-secret-123" and "a-guessed-secret-123" not in repr(parsed)


@pytest.mark.parametrize("first", [frame(TRACKER), frame(KEY), b"\xc1"])
def test_a_first_frame_that_is_not_a_hello_is_refused(first):
    g, _ = gate()
    s = Session(7, "msgpack", SERVER, T0, gate=g)
    s.set_scene("aaaa", SCENE)
    assert s.receive(first, T0 + 1) == []
    out = kinds(sent(s))
    assert out[-2:] == ["unauthorized", Close(1008)] and "welcome" not in out
    assert out[:-2] in ([], ["bad_encoding"])


def test_no_hello_within_the_grace_period_is_refused():
    g, _ = gate()
    s = Session(7, "msgpack", SERVER, T0, gate=g)
    assert s.hello_wait_s(T0) == pytest.approx(HELLO_TIMEOUT_NS / 1e9)
    assert s.hello_wait_s(T0 + HELLO_TIMEOUT_NS // 4) == pytest.approx(0.75 * HELLO_TIMEOUT_NS / 1e9)
    s.hello_deadline_passed(T0 + HELLO_TIMEOUT_NS - 1)
    assert sent(s) == []
    s.hello_deadline_passed(T0 + HELLO_TIMEOUT_NS)
    assert kinds(sent(s)) == ["unauthorized", Close(1008)] and s.hello_wait_s(T0 + HELLO_TIMEOUT_NS) is None


def test_a_session_without_access_control_admits_nobody():
    s = Session(7, "msgpack", SERVER, T0)  # the default gate fails closed
    s.receive(hello("observer", "admin-secret"), T0)
    assert kinds(sent(s)) == ["unauthorized", Close(1008)]


def test_the_connection_cap_refuses_with_rate_limited_and_closes():
    s, _ = connect(ADMIN, admit=lambda who: f"token {who.token_id} already has 256 connections open")
    assert kinds(sent(s)) == ["rate_limited", Close(1008)] and not s.welcomed


def test_the_policy_can_refuse_the_hello_itself(monkeypatch):
    monkeypatch.setitem(POLICY, "ws:hello", POLICY["ws:hello"].__class__(roles=frozenset({"admin"})))
    s, _ = connect(OBSERVER, "observer")
    out = sent(s)
    assert kinds(out) == ["forbidden", Close(1008)]


# ---- the role granted -----------------------------------------------------------------------------
# token role -> {asked: granted}; a role above what the token allows is granted the highest it allows
GRANTS = {
    ADMIN: {"operator": "operator", "participant": "participant", "observer": "observer"},
    EXP_A: {"operator": "operator", "participant": "participant", "observer": "observer"},
    PART_1: {"operator": "participant", "participant": "participant", "observer": "observer"},
    OBSERVER: {"operator": "observer", "participant": "observer", "observer": "observer"},
}


@pytest.mark.parametrize("who", list(GRANTS), ids=lambda w: w.role)
@pytest.mark.parametrize("asked", ["operator", "participant", "observer"])
def test_the_welcome_grants_the_role_the_token_allows_and_says_who_it_is(who, asked):
    s, _ = connect(who, asked)
    out = sent(s)
    granted = GRANTS[who][asked]
    welcome = out[0]
    assert welcome["type"] == "welcome" and welcome["role"] == granted == s.role and welcome["minor"] == 6  # v1.6 (was 5)
    assert welcome["identity"] == {"token_id": who.token_id, "role": who.role, "site": who.site,
                                   "session": who.session}
    if granted == asked:
        assert kinds(out) == ["welcome", "scene"]
    else:  # welcomed with the allowed role plus one forbidden error
        assert kinds(out) == ["welcome", "scene", "forbidden"] and asked in out[2]["message"]
    assert not s.closing


# ---- every client message type x role x lease state, against POLICY -----------------------------
def test_every_client_message_type_has_a_policy_entry():
    missing = [f"ws:{name}" for name in CLIENT_MESSAGE_NAMES if f"ws:{name}" not in POLICY]
    assert not missing, f"client message types without a policy entry: {missing}"
    assert "ws:input:operator" in POLICY
    assert set(SAMPLE) | {"hello"} == set(CLIENT_MESSAGE_NAMES), "a new client message type needs a case here"


def _lease_state(state: str, who) -> Lease:
    """free | mine (who holds it) | other (EXP_B holds it) | other-open-s1 (EXP_B holds it, opened
    participant session s-1)."""
    lease = Lease(60.0, clock=Clock())
    if state == "mine":
        assert lease.request(who)["status"] == "granted"
    elif state.startswith("other"):
        lease.request(EXP_B)
        if state == "other-open-s1":
            lease.open_session(EXP_B, "s-1")
    return lease


# Who may send tracker/input as a participant connection (the hand-written expectation of the
# contract: the holder's own connections, and a participant token of the session it opened).
def _may_drive(who, state: str) -> bool:
    if who.role in ("admin", "experimenter"):
        return state == "mine"
    if who.role == "participant":
        return state == "other-open-s1" and who.session == "s-1"
    return False


WHO = [ADMIN, EXP_A, PART_1, PART_2, OBSERVER]
STATES = ["free", "mine", "other", "other-open-s1"]
# every token role x lease state that can occur (participant and observer tokens never hold the lease)
CASES = [pytest.param(who, state, id=f"{who.role}-{who.token_id}-{state}") for who in WHO for state in STATES
         if not (state == "mine" and who.role in ("participant", "observer"))]


@pytest.mark.parametrize("kind", DRIVING)
@pytest.mark.parametrize("who, state", CASES)
def test_each_message_is_allowed_exactly_when_the_policy_and_the_lease_say_so(kind, who, state):
    lease = _lease_state(state, who)
    s, _ = connect(who, "participant", lease)
    sent(s)
    allowed_by_policy = decide(POLICY[f"ws:{kind}"], who, lease) is None
    expected = _may_drive(who, state) and s.role != "observer"
    assert allowed_by_policy == _may_drive(who, state), "POLICY disagrees with the contract's drive rule"
    events = s.receive(frame(SAMPLE[kind]), T0 + 10)
    if expected:
        assert len(events) == 1 and sent(s) == []
        assert isinstance(events[0], ToLoop if kind == "tracker" else Command)
    else:
        assert events == []
        (error,) = sent(s)
        assert error["code"] == "forbidden"


@pytest.mark.parametrize("who, state", CASES)
def test_experimenter_commands_need_an_operator_connection_of_the_lease_holder(who, state):
    lease = _lease_state(state, who)
    s, _ = connect(who, "operator", lease)
    allowed = s.refusal("input:operator") is None
    assert allowed == (who.role in ("admin", "experimenter") and state == "mine")
    assert allowed == (s.role == "operator" and decide(POLICY["ws:input:operator"], who, lease) is None)


def test_an_observer_connection_of_the_holder_may_not_send():
    lease = _lease_state("mine", ADMIN)
    s, _ = connect(ADMIN, "observer", lease)
    sent(s)
    for kind in sorted(SAMPLE):
        assert s.receive(frame(SAMPLE[kind]), T0 + 1) == []
        assert [m["code"] for m in sent(s)] == ["forbidden"]


def test_refused_tracker_samples_get_one_error_a_second():
    s, _ = connect(PART_2, "participant", _lease_state("other-open-s1", PART_2))
    sent(s)
    for i in range(1000):  # a 1 kHz stream for one second
        assert s.receive(frame({**TRACKER, "seq": i}), T0 + 10 + i * 1_000_000) == []
    assert [m["code"] for m in sent(s)] == ["forbidden"] and s.errors == 1000
    s.receive(frame(TRACKER), T0 + 10 + FORBIDDEN_TRACKER_ERROR_EVERY_NS)
    assert [m["code"] for m in sent(s)] == ["forbidden"]


# ---- the lease message and losing the right to drive ------------------------------------------------
def test_the_lease_message_follows_welcome_scene_and_health_and_every_change():
    lease = _lease_state("mine", EXP_A)
    g, _ = gate(lease)
    s = Session(7, "msgpack", SERVER, T0, gate=g)
    s.set_scene("aaaa", SCENE)
    s.set_health({fmt: codec.encode(messages.health("ok", []), fmt) for fmt in codec.FORMATS})
    s.set_lease(lease_frames(lease))
    assert sent(s) == []  # nothing before the welcome
    s.receive(hello("operator", SECRET[EXP_A.token_id]), T0)
    out = sent(s)
    assert kinds(out) == ["welcome", "scene", "health", "lease"]
    assert out[3]["holder"]["token_id"] == EXP_A.token_id and out[3]["queue"] == []
    lease.request(EXP_B)
    s.set_lease(lease_frames(lease))
    lease.open_session(EXP_A, "s-1")
    s.set_lease(lease_frames(lease))  # supersedes the one not yet sent
    (latest,) = sent(s)
    assert latest["type"] == "lease" and latest["session"] == "s-1"
    assert [q["token_id"] for q in latest["queue"]] == [EXP_B.token_id]


def test_a_driver_that_loses_the_lease_leaves_the_hip_once():
    lease = _lease_state("mine", EXP_A)
    s, _ = connect(EXP_A, "participant", lease)
    watcher, _ = connect(EXP_A, "participant", lease)  # holds the same right, never drove
    assert len(s.receive(frame(TRACKER), T0 + 1)) == 1
    assert s.set_lease(lease_frames(lease)) == []  # still the holder: nothing changes
    lease.release(EXP_A)
    assert s.set_lease(lease_frames(lease)) == [ToLoop(TrackerGone(7))]
    assert watcher.set_lease(lease_frames(lease)) == []
    assert s.set_lease(lease_frames(lease)) == []  # once
    assert s.receive(frame(TRACKER), T0 + 2) == []  # and its samples are refused now


def test_a_participant_of_a_session_that_is_no_longer_open_leaves_the_hip():
    lease = _lease_state("other-open-s1", PART_1)
    s, _ = connect(PART_1, "participant", lease)
    assert len(s.receive(frame(TRACKER), T0 + 1)) == 1
    lease.open_session(EXP_B, "s-2")
    assert s.set_lease(lease_frames(lease)) == [ToLoop(TrackerGone(7))]
    other, _ = connect(PART_2, "participant", lease)
    assert len(other.receive(frame(TRACKER), T0 + 2)) == 1


# ---- a participant's study answers (v1.5 `answer`, `ask`) ---------------------------------------------------
@pytest.mark.parametrize("who, state", CASES)
def test_only_a_participant_connection_of_a_participant_token_may_answer_and_only_for_its_own_session(who, state):
    """The lease does not matter (the running trial is the experimenter's permission); the session
    answered is always the token's own: a participant of s-2 cannot reach s-1's trial."""
    lease = _lease_state(state, who)
    s, _ = connect(who, "participant", lease)
    sent(s)
    events = s.receive(frame(ANSWER), T0 + 10)
    if who.role == "participant":
        assert sent(s) == []
        assert events == [ParticipantAnswer(who.session, 3, "roughness", 5.0, who, 7)]
    else:
        assert events == []
        (error,) = sent(s)
        assert error["code"] == "forbidden"
        assert ("an observer may not" if who.role == "observer" else "allowed: participant") in error["message"]


def test_an_observer_connection_of_a_participant_token_and_a_token_without_a_session_may_not_answer():
    s, _ = connect(PART_1, "observer")
    sent(s)
    assert s.receive(frame(ANSWER), T0 + 1) == [] and [m["code"] for m in sent(s)] == ["forbidden"]
    loose = Identity("par00009", "participant", site="lab-a", session=None)
    g, _ = gate()
    s = Session(7, "msgpack", SERVER, T0, gate=Gate(lambda secret: loose, g.lease))
    s.receive(hello("participant", "anything"), T0)
    sent(s)
    assert s.receive(frame(ANSWER), T0 + 1) == []
    (error,) = sent(s)
    assert error["code"] == "forbidden" and "names no session" in error["message"]


def test_answers_spend_the_input_budget():
    s, _ = connect(PART_1, "participant")
    sent(s)
    got = [s.receive(frame(ANSWER), T0 + 10) for _ in range(INPUT_BURST + 1)]
    assert all(len(e) == 1 for e in got[:INPUT_BURST]) and got[-1] == []
    assert [m["code"] for m in sent(s)] == ["rate_limited"]


@pytest.mark.parametrize("who, state", CASES)
def test_any_page_but_an_observers_may_offer_its_actuators_and_takes_them_away_when_it_leaves(who, state):
    """v1.6 `actuators`: offering moves nothing on the rig, so no lease rule; an observer may not."""
    for role in ("participant", "observer"):
        s, _ = connect(who, role, _lease_state(state, who))
        sent(s)
        events = s.receive(frame(ACTUATORS), T0 + 1)
        if role == "observer" or who.role == "observer":
            assert events == [] and [m["code"] for m in sent(s)] == ["forbidden"]
            assert s.disconnected() == []
        else:
            assert events == [ActuatorsOffered(7, (("xr", "right"),), "")] and sent(s) == []
            assert s.disconnected() == [ActuatorsOffered(7, (), "", left=True)]


def _asks(session_id: str, seq) -> dict:
    view = {"session": session_id, "seq": seq, "task": "t", "questions": [], "audio": {"speech": True},
            "instructions": ""}
    return {fmt: codec.encode(messages.ask(view), fmt) for fmt in codec.FORMATS}


def test_ask_goes_to_participant_connections_of_its_session_after_the_welcome_and_supersedes():
    s, _ = connect(PART_1, "participant")
    assert s.asks_for == "s-1"
    s.set_ask(_asks("s-1", 0))
    s.set_ask(_asks("s-1", 1))  # the newer one replaces the one not yet sent
    out = sent(s)
    assert kinds(out)[-1] == "ask" and [m["seq"] for m in out if m["type"] == "ask"] == [1]
    assert out[-1]["audio"] == {"speech": True, "contact_sounds": False}
    # held before the welcome, sent right after it
    g, _ = gate()
    late = Session(8, "msgpack", SERVER, T0, gate=g)
    late.set_ask(_asks("s-1", 2))
    assert sent(late) == [] and late.asks_for is None
    late.receive(hello("participant", SECRET[PART_1.token_id]), T0)
    assert late.asks_for == "s-1"
    # observers and staff have no session to be asked about
    for who, role in ((PART_1, "observer"), (EXP_A, "participant"), (ADMIN, "operator")):
        other, _ = connect(who, role)
        assert other.asks_for is None
        sent(other)
        other.set_ask(_asks("s-1", 3))
        assert "ask" not in kinds(sent(other))
