"""The policy table: every operation and client message has a rule; decide() by role and lease."""

from __future__ import annotations

import pytest

from server.auth.identity import Identity
from server.auth.lease import Lease
from server.auth.policy import POLICY, Rule, decide
from server.wire.messages import CLIENT_MESSAGES

ADMIN = Identity("a0000001", "admin")
EXP = Identity("e0000001", "experimenter", "lab-a")
EXP_B = Identity("e0000002", "experimenter", "lab-b")
PART = Identity("p0000001", "participant", "lab-a", session="s1")
OBS = Identity("o0000001", "observer")


def _operations() -> set[str]:
    from server.app import create_app
    from server.config import Settings

    paths = create_app(Settings()).openapi()["paths"]
    return {f"{method.upper()} {path}" for path, ops in paths.items() for method in ops}


def test_every_operation_of_the_api_has_a_rule():
    missing = sorted(_operations() - POLICY.keys())
    assert missing == []


def test_every_client_message_type_has_a_rule():
    assert {f"ws:{kind}" for kind in CLIENT_MESSAGES} <= POLICY.keys()
    assert "ws:input:operator" in POLICY


def test_state_changes_need_the_lease_and_reads_do_not():
    for key, rule in POLICY.items():
        method = key.split()[0]
        if method in ("POST", "PUT", "DELETE", "PATCH") and rule.roles:
            exempt = key.startswith(("POST /api/lease", "DELETE /api/lease", "POST /api/auth/", "POST /api/tokens",
                                     "DELETE /api/tokens"))
            # a session's own records are the site's data, not the rig: only a trial start runs on the
            # rig, and a paced task's resume (it starts the next trial)
            site_data = "/api/sessions" in key and not key.endswith(("/start", "/pacing/resume"))
            # the caller's own things: a participant's own session placement (the handler finds
            # whose; staff only for the session their lease opened)
            own = key == "PUT /api/placement/session" and rule.scope == "self"
            assert rule.lease or exempt or site_data or own, key
            assert not (site_data and rule.lease), key
        if method == "GET":
            assert not rule.lease, key
    assert POLICY["POST /api/sessions/{session_id}/trials/{seq}/start"].lease
    assert POLICY["POST /api/sessions/{session_id}/pacing/resume"].lease
    assert POLICY["GET /api/health"].roles == frozenset()
    assert all(POLICY[k].scope == "site" for k in POLICY if "/sessions" in k)
    assert all(POLICY[k].roles == {"admin"} for k in POLICY if "/tokens" in k)


def test_rules_refuse_nonsense():
    with pytest.raises(ValueError):
        Rule(frozenset({"root"}))
    with pytest.raises(ValueError):
        Rule(frozenset({"admin"}), scope="public")
    with pytest.raises(ValueError):
        Rule(frozenset(), scope="rig")


def _expected(rule: Rule, who: Identity | None, lease: Lease) -> int | None:
    """The table read by hand, independent of decide()'s order of checks."""
    if not rule.roles:
        return None
    if who is None:
        return 401
    ok = who.role in rule.roles and (not rule.lease or lease.holds(who)) and (not rule.drive or lease.may_drive(who))
    return None if ok else 403


@pytest.mark.parametrize("holder", [None, EXP, ADMIN])
def test_decide_matrix(clock, holder):
    lease = Lease(60.0, clock)
    if holder is not None:
        lease.request(holder)
        lease.open_session(holder, "s1")
    for key, rule in POLICY.items():
        for who in (None, OBS, PART, EXP, EXP_B, ADMIN):
            got = decide(rule, who, lease)
            assert (got[0] if got else None) == _expected(rule, who, lease), (key, who, holder)


def test_examples_of_the_issue(clock):
    lease = Lease(60.0, clock)
    scenario = POLICY["POST /api/scenario"]
    assert decide(scenario, None, lease)[0] == 401
    assert decide(scenario, OBS, lease)[0] == 403
    assert decide(scenario, EXP, lease)[0] == 403  # no lease
    lease.request(EXP)
    assert decide(scenario, EXP, lease) is None
    assert decide(scenario, ADMIN, lease)[0] == 403  # admins too need the lease
    assert decide(POLICY["ws:tracker"], PART, lease)[0] == 403  # session not open
    lease.open_session(EXP, "s1")
    assert decide(POLICY["ws:tracker"], PART, lease) is None
    assert decide(POLICY["ws:input:operator"], PART, lease)[0] == 403
    assert decide(POLICY["ws:tracker"], EXP_B, lease)[0] == 403
    assert decide(POLICY["GET /api/sessions"], OBS, lease)[0] == 403
    assert decide(POLICY["GET /api/health"], None, lease) is None
