"""The role × operation matrix: every operation of /openapi.json, called by every kind of caller,
is refused exactly when the declared policy (server/auth/policy.py) says so, with the status it
says (401 without a valid token, 403 for the role or the lease, 409 for what would change another
lab's running trial); and every operation has a policy, so a new endpoint without one fails here
(the guard refuses it anyway: fail closed). Two columns beside the roles (issue 35): "during
another lab's running trial" (a trial of lab-b's session is recorded) and "after revocation" (each
role's token revoked before the call: 401 everywhere but on the public operations).

In process (the app without its lifespan: no loop, no devices): the guard runs before any handler,
so what the handlers answer without a loop (503, 404, 422, ...) does not matter here, only that an
allowed call is not refused by the guard and a refused one is."""

from __future__ import annotations

import asyncio
import re
from dataclasses import replace

import httpx
import pytest

from server.app import create_app
from server.auth.identity import Identity
from server.auth.policy import POLICY, RunningTrial, decide
from server.auth.ratelimit import FailureThrottle
from server.config import Settings

PATH_VALUES = {"session_id": "s-unknown", "seq": "0", "question": "rating", "study_id": "thesis-2021",
               "token_id": "00000000", "source": "leap"}
ROLE_CALLERS = ("none", "observer", "participant", "experimenter", "experimenter+lease", "admin+lease")
DURING_TRIAL = ("participant@trial", "experimenter+lease@trial", "admin+lease@trial")  # lab-b's trial runs
REVOKED = ("observer@revoked", "participant@revoked", "experimenter@revoked", "admin@revoked")
CALLERS = ROLE_CALLERS + DURING_TRIAL + REVOKED
OTHER_LABS_TRIAL = RunningTrial("s-lab-b", "lab-b")
REVOKED_REASON = "the token is unknown, expired or revoked"


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    return create_app(Settings(data_dir=tmp_path_factory.mktemp("data"), tracker_udp="off"))


@pytest.fixture(scope="module")
def document(app):
    return app.openapi()


def operations(document) -> list[str]:
    return [f"{method.upper()} {path}" for path, methods in document["paths"].items() for method in methods]


def test_every_operation_has_a_policy(document):
    ops = operations(document)
    assert len(ops) > 40, ops
    missing = [op for op in ops if op not in POLICY]
    assert not missing, f"operations without an access policy (server/auth/policy.py): {missing}"


def test_every_rest_policy_names_an_operation(document):
    ops = set(operations(document))
    stale = [key for key in POLICY if not key.startswith("ws:") and key not in ops]
    assert not stale, f"policies of operations that do not exist: {stale}"


def test_every_guarded_operation_documents_the_guards_answers_and_the_bearer_scheme(document):
    assert document["components"]["securitySchemes"]["HTTPBearer"] == {
        "type": "http", "scheme": "bearer", "description": document["components"]["securitySchemes"]["HTTPBearer"][
            "description"]}
    for path, methods in document["paths"].items():
        for method, op in methods.items():
            assert {"401", "403", "429"} <= set(op["responses"]), (method, path)
            assert {"HTTPBearer": []} in op["security"], (method, path)
            assert "Retry-After" in op["responses"]["429"]["headers"], (method, path)


class Callers:
    """A token of each kind in the app's own book, and the lease arranged for each call."""

    def __init__(self, access):
        self.access = access
        self.secrets: dict[str, str | None] = {"none": None}
        self.who: dict[str, Identity | None] = {"none": None}
        grants = {"observer": ("observer", None, None), "participant": ("participant", "lab-a", "s-unknown"),
                  "experimenter": ("experimenter", "lab-a", None), "admin": ("admin", None, None)}
        for caller, (role, site, session) in grants.items():
            self.secrets[caller], self.who[caller] = access.book.create(role, site, session=session, label=caller)
        for caller, base in (("experimenter+lease", "experimenter"), ("admin+lease", "admin")):
            self.secrets[caller], self.who[caller] = self.secrets[base], self.who[base]
        for caller in DURING_TRIAL:
            self.secrets[caller], self.who[caller] = self.secrets[caller[:-6]], self.who[caller[:-6]]
        for caller in REVOKED:  # a token of its own, revoked before any call
            role, site, session = grants[caller[:-8]]
            self.secrets[caller], self.who[caller] = access.book.create(role, site, session=session, label=caller)
            assert access.revoke(self.who[caller].token_id)

    def running(self, caller: str) -> RunningTrial | None:
        return OTHER_LABS_TRIAL if caller in DURING_TRIAL else None

    def expected(self, key: str, caller: str) -> tuple[int, str] | None:
        """The guard's answer by the declared policy: None (allowed) or (status, reason)."""
        rule = POLICY[key]
        if caller in REVOKED:  # the token is no credential any more: anonymous, refused unless public
            return (401, REVOKED_REASON) if rule.roles else None
        return decide(rule, self.who[caller], self.access.lease, self.running(caller) if rule.recorded else None)

    def arrange(self, caller: str) -> None:
        """The lease held by the caller (…+lease), else by the admin; nobody queued; no session open;
        a trial of lab-b recorded for the …@trial callers; a fresh failed-attempt throttle (the revoked
        tokens fail on every call: their count is not what this matrix is about)."""
        self.access.running = lambda: self.running(caller)
        self.access.throttle = FailureThrottle()
        lease = self.access.lease
        snapshot = lease.snapshot()
        for entry in ([snapshot["holder"]] if snapshot["holder"] else []) + snapshot["queue"]:
            lease.drop(entry["token_id"])
        lease.session = None
        holder = self.who["experimenter"] if caller.startswith("experimenter+lease") else self.who["admin"]
        assert lease.request(holder)["status"] == "granted"


def _url(key: str) -> tuple[str, str]:
    method, path = key.split(" ", 1)
    return method, re.sub(r"\{(\w+)\}", lambda m: PATH_VALUES[m.group(1)], path)


def test_each_caller_is_refused_exactly_where_the_policy_says(app, document):
    access = app.state.access
    callers = Callers(access)
    reasons = {REVOKED_REASON}
    for caller in CALLERS:  # the guard's refusals in words, to tell them from a handler's own 403
        callers.arrange(caller)
        for key in POLICY:
            refusal = callers.expected(key, caller)
            if refusal:
                reasons.add(refusal[1])
    checked = []

    async def run() -> None:
        transport = httpx.ASGITransport(app=app, raise_app_exceptions=False)
        async with httpx.AsyncClient(transport=transport, base_url="http://127.0.0.1") as client:
            for key in operations(document):
                method, url = _url(key)
                for caller in CALLERS:
                    callers.arrange(caller)
                    expected = callers.expected(key, caller)
                    secret = callers.secrets[caller]
                    headers = {"Authorization": f"Bearer {secret}"} if secret else {}
                    body = {} if method in ("POST", "PUT") else None
                    answer = await client.request(method, url, headers=headers, json=body)
                    detail = answer.json().get("detail") if answer.headers.get("content-type", "").startswith(
                        "application/json") and isinstance(answer.json(), dict) else None
                    if expected is None:
                        assert answer.status_code != 401 and not (answer.status_code == 403 and detail in reasons), \
                            (key, caller, answer.status_code, detail)
                    else:
                        assert (answer.status_code, detail) == expected, (key, caller)
                        if expected[0] == 401:
                            assert answer.headers["www-authenticate"] == "Bearer", (key, caller)
                    checked.append((key, caller, expected is None))

    asyncio.run(run())
    allowed = {(key, caller) for key, caller, ok in checked if ok}
    assert len(checked) == len(operations(document)) * len(CALLERS)
    # the matrix is not trivially all-allowed or all-refused: spot checks of the policy's intent
    assert ("POST /api/scenario", "admin+lease") in allowed and ("POST /api/scenario", "experimenter") not in allowed
    assert ("GET /api/sessions", "observer") not in allowed and ("GET /api/health", "none") in allowed
    assert ("POST /api/sessions/{session_id}/control", "none") not in allowed
    # a session's psychophysics tracks are read as the session itself is (the console's live track)
    assert ("GET /api/sessions/{session_id}/tracks", "experimenter") in allowed
    assert {("GET /api/sessions/{session_id}/tracks", c) for c in ("none", "observer")}.isdisjoint(allowed)
    assert replace(POLICY["GET /api/sessions/{session_id}/tracks"], doc="") == \
        replace(POLICY["GET /api/sessions/{session_id}"], doc="")
    # during another lab's running trial: what reaches its recording is refused (409, naming the lab)
    # to another lab's lease holder, not to the admin; reading and the site's own records are not
    refused_in_trial = {key for key, caller, ok in checked if caller == "experimenter+lease@trial" and not ok}
    assert {"POST /api/command", "PUT /api/trackers/{source}/calibration"} <= refused_in_trial
    assert ("POST /api/command", "admin+lease@trial") in allowed
    callers.arrange("experimenter+lease@trial")
    assert callers.expected("POST /api/command", "experimenter+lease@trial")[0] == 409
    assert "lab-b" in callers.expected("POST /api/command", "experimenter+lease@trial")[1]
    assert ("GET /api/scene", "experimenter+lease@trial") in allowed
    # after revocation: nothing but the public operations
    assert {key for key, caller, ok in checked if caller == "admin@revoked" and ok} == \
        {key for key in operations(document) if not POLICY[key].roles}
    access.running = lambda: None


def test_a_route_without_a_policy_is_refused(app, monkeypatch):
    """Fail closed: the guard refuses an operation the table does not declare."""
    monkeypatch.delitem(POLICY, "GET /api/scenarios")
    callers = Callers(app.state.access)
    callers.arrange("admin+lease")

    async def run() -> httpx.Response:
        transport = httpx.ASGITransport(app=app, raise_app_exceptions=False)
        async with httpx.AsyncClient(transport=transport, base_url="http://127.0.0.1") as client:
            return await client.get("/api/scenarios", headers={"Authorization": f"Bearer {callers.secrets['admin']}"})

    answer = asyncio.run(run())
    assert answer.status_code == 403 and "no declared access policy" in answer.json()["detail"], answer.text
