"""Access control over REST against a real server (issue 19): the outsider's attempts of the issue
fail with 401/403/404 and change nothing; a rig change while a session's trial is recorded is a
409; two labs share the rig (the lease queue, on release and on expiry; neither sees the other's
sessions or audit rows); the lease survives a restart."""

from __future__ import annotations

import json
import time
import urllib.error
import urllib.request

import pytest

from tests.live_server import admin_token, start_server, stop_server

STUDY = "thesis-2021"
EVIL = {"Origin": "http://evil.example"}
ADMIN = object()  # call(): the harness's admin token


def call(base: str, method: str, path: str, body: dict | None = None, token=ADMIN,
         headers: dict | None = None) -> tuple[int, object]:
    if token is ADMIN:
        token = admin_token(base)
    data = json.dumps(body).encode() if body is not None else None
    request = urllib.request.Request(base + path, data=data, method=method, headers={
        "Content-Type": "application/json", **({"Authorization": f"Bearer {token}"} if token else {}),
        **(headers or {})})
    try:
        with urllib.request.urlopen(request, timeout=10) as response:
            return response.status, json.loads(response.read())
    except urllib.error.HTTPError as exc:
        return exc.code, json.loads(exc.read() or b"null")


def ok(answer: tuple[int, object], status: int = 200):
    assert answer[0] == status, answer
    return answer[1]


def new_token(base: str, role: str, site: str | None = None) -> str:
    return ok(call(base, "POST", "/api/tokens", {"role": role, "site": site, "label": f"test {role}"}), 201)["token"]


@pytest.fixture(scope="module")
def base():
    proc, url = start_server()
    try:
        yield url
    finally:
        stop_server(proc)


def session_attempts(session: str, control: str) -> list[tuple[str, str, dict | None, dict]]:
    """What the outsider tried on a session: (method, path, body, extra headers)."""
    return [("GET", "/api/sessions", None, {}),
            ("GET", f"/api/sessions/{session}", None, {}),
            ("POST", f"/api/sessions/{session}/control", {"experimenter": "mallory"}, {}),
            ("PUT", f"/api/sessions/{session}/notes", {"notes": "pwned"}, {"X-Control-Token": control}),
            ("POST", f"/api/sessions/{session}/trials/0/start", None, {"X-Control-Token": control}),
            ("POST", f"/api/sessions/{session}/trials/0/finish", None, {"X-Control-Token": control}),
            ("POST", f"/api/sessions/{session}/trials/0/exclude", {"reason": "x"}, {"X-Control-Token": control})]


RIG_ATTEMPTS = [("POST", "/api/scenario", {"name": "texture"}), ("POST", "/api/trial", {"phase": "main"}),
                ("DELETE", "/api/trial", None), ("POST", "/api/command", {"key": "n"})]


def test_the_outsiders_attempts_fail_and_change_nothing(base):
    created = ok(call(base, "POST", "/api/sessions", {"study": STUDY, "participant": "P-out1",
                                                      "experimenter": "ann", "notes": "real"}), 201)
    sid, control = created["id"], created["token"]
    scenario = ok(call(base, "GET", "/api/scenario"))["id"]
    observer = new_token(base, "observer")
    other_lab = new_token(base, "experimenter", "lab-z")
    for method, path, body in RIG_ATTEMPTS:  # no token, from a foreign page
        # from a foreign page the Origin check refuses a change first (403); without a token the guard (401)
        assert call(base, method, path, body, token=None, headers=EVIL)[0] == 403, (method, path)
        assert call(base, method, path, body, token=None)[0] == 401, (method, path)
        assert call(base, method, path, body, token=observer)[0] == 403, (method, path)
        assert call(base, method, path, body, token=other_lab)[0] == 403, (method, path)  # no lease
    for method, path, body, extra in session_attempts(sid, control):
        expected = 401 if method == "GET" else 403  # reads pass the Origin check and meet the guard
        assert call(base, method, path, body, token=None, headers={**EVIL, **extra})[0] == expected, (method, path)
        assert call(base, method, path, body, token=None, headers=extra)[0] == 401, (method, path)
        assert call(base, method, path, body, token=observer, headers=extra)[0] == 403, (method, path)
    # another lab's experimenter, even holding the lease: the session does not exist for it
    ok(call(base, "POST", "/api/lease/force-release"))
    assert ok(call(base, "POST", "/api/lease", token=other_lab))["status"] == "granted"
    try:
        for method, path, body, extra in session_attempts(sid, control)[1:]:
            assert call(base, method, path, body, token=other_lab, headers=extra)[0] == 404, (method, path)
        assert sid not in [s["id"] for s in ok(call(base, "GET", "/api/sessions", token=other_lab))]
        rows = ok(call(base, "GET", "/api/audit?limit=1000", token=other_lab))
        assert rows and all(r["site"] == "lab-z" for r in rows), rows
    finally:
        ok(call(base, "DELETE", "/api/lease", token=other_lab))
        ok(call(base, "POST", "/api/lease"))
    # nothing changed, and the real console still controls its session
    assert ok(call(base, "GET", "/api/scenario"))["id"] == scenario
    session = ok(call(base, "GET", f"/api/sessions/{sid}"))
    assert session["notes"] == "real" and session["trials"][0]["status"] == "pending"
    assert ok(call(base, "GET", f"/api/sessions/{sid}/control", headers={"X-Control-Token": control}))["yours"]
    # and the audit log has the refusals, with who tried
    rows = ok(call(base, "GET", f"/api/audit?session_id={sid}&limit=1000"))
    refused = [(r["role"], r["result"]) for r in rows if r["action"] == "PUT /api/sessions/{session_id}/notes"]
    assert (None, "refused 401") in refused and ("observer", "refused 403") in refused, refused
    assert ("experimenter", "refused 404") in refused, refused


def test_a_rig_change_during_a_recorded_trial_is_refused(base):
    created = ok(call(base, "POST", "/api/sessions", {"study": STUDY, "participant": "P-409", "experimenter": "ann"}),
                 201)
    sid, control = created["id"], {"X-Control-Token": created["token"]}
    ok(call(base, "POST", f"/api/sessions/{sid}/trials/0/start", headers=control))
    try:
        for method, path, body in RIG_ATTEMPTS[:3]:
            status, answer = call(base, method, path, body)
            assert status == 409 and sid in answer["detail"], (method, path, answer)
        assert ok(call(base, "GET", f"/api/sessions/{sid}"))["running"] == 0
    finally:
        ok(call(base, "POST", f"/api/sessions/{sid}/trials/0/abort", {"reason": "test"}, headers=control))
    assert ok(call(base, "POST", "/api/scenario", {"name": "contact-angle"}))["id"].startswith("contact-angle")


def test_a_lab_that_lost_the_lease_mid_trial_still_closes_its_trial(base):
    lab = new_token(base, "experimenter", "lab-a")
    ok(call(base, "DELETE", "/api/lease"))
    try:
        assert ok(call(base, "POST", "/api/lease", token=lab))["status"] == "granted"
        created = ok(call(base, "POST", "/api/sessions", {"study": STUDY, "participant": "P-lost1",
                                                          "experimenter": "al"}, token=lab), 201)
        sid, control = created["id"], {"X-Control-Token": created["token"]}
        ok(call(base, "POST", f"/api/sessions/{sid}/trials/0/start", token=lab, headers=control))
        ok(call(base, "POST", "/api/lease/force-release"))  # the admin takes the rig mid-trial
        ok(call(base, "POST", "/api/lease"))
        # the rig stays with the trial (409 for the new holder) until its own lab closes it, lease or not
        assert call(base, "POST", "/api/scenario", {"name": "texture"})[0] == 409
        ok(call(base, "PUT", f"/api/sessions/{sid}/notes", {"notes": "lease lost at trial 0"}, token=lab,
                headers=control))
        ok(call(base, "POST", f"/api/sessions/{sid}/trials/0/abort", {"reason": "lease lost"}, token=lab,
                headers=control))
        assert call(base, "POST", f"/api/sessions/{sid}/trials/0/start", token=lab, headers=control)[0] == 403
        session = ok(call(base, "GET", f"/api/sessions/{sid}", token=lab))
        assert session["notes"] == "lease lost at trial 0" and session["trials"][0]["status"] == "aborted", session
        ok(call(base, "POST", "/api/scenario", {"name": "contact-angle"}))
    finally:
        if ok(call(base, "GET", "/api/lease"))["you"] != "holder":
            ok(call(base, "POST", "/api/lease/force-release"))
            ok(call(base, "POST", "/api/lease"))


def test_two_labs_share_the_rig(tmp_path):
    proc, base = start_server(extra=["--lease-ttl", "2"], take_lease=False)
    try:
        a, b = new_token(base, "experimenter", "lab-a"), new_token(base, "experimenter", "lab-b")
        assert ok(call(base, "POST", "/api/lease", token=a))["status"] == "granted"
        queued = ok(call(base, "POST", "/api/lease", token=b))
        assert (queued["status"], queued["position"]) == ("queued", 1)
        # queued, b prepares its session (its own records) but may not run a trial on the rig
        created = ok(call(base, "POST", "/api/sessions", {"study": STUDY, "participant": "PB2", "experimenter": "bo"},
                          token=b), 201)
        sb, b_control = created["id"], {"X-Control-Token": created["token"]}
        start_b = f"/api/sessions/{sb}/trials/0/start"
        assert call(base, "POST", start_b, token=b, headers=b_control)[0] == 403  # queued is not holding
        assert call(base, "POST", "/api/scenario", {"name": "texture"}, token=b)[0] == 403
        sa = ok(call(base, "POST", "/api/sessions", {"study": STUDY, "participant": "PA1", "experimenter": "al"},
                     token=a), 201)["id"]
        ok(call(base, "POST", "/api/lease/renew", token=b))
        ok(call(base, "DELETE", "/api/lease", token=a))  # released: the next in the queue has it
        assert ok(call(base, "GET", "/api/lease", token=b))["you"] == "holder"
        ok(call(base, "POST", start_b, token=b, headers=b_control))
        ok(call(base, "POST", f"/api/sessions/{sb}/trials/0/abort", {"reason": "test"}, token=b, headers=b_control))
        # neither lab sees the other's sessions; the admin sees both
        assert [s["id"] for s in ok(call(base, "GET", "/api/sessions", token=a))] == [sa]
        assert [s["id"] for s in ok(call(base, "GET", "/api/sessions", token=b))] == [sb]
        assert call(base, "GET", f"/api/sessions/{sb}", token=a)[0] == 404
        assert call(base, "GET", f"/api/sessions/{sa}", token=b)[0] == 404
        assert {sa, sb} <= {s["id"] for s in ok(call(base, "GET", "/api/sessions"))}
        # expiry: b goes quiet, a (queued, renewing) gets the lease within the ttl and a tick or two
        assert ok(call(base, "POST", "/api/lease", token=a))["status"] == "queued"
        deadline = time.monotonic() + 10
        while ok(call(base, "GET", "/api/lease", token=a))["you"] != "holder":
            assert time.monotonic() < deadline, ok(call(base, "GET", "/api/lease", token=a))
            time.sleep(0.3)
        lease = ok(call(base, "GET", "/api/lease", token=b))
        assert lease["you"] == "none" and lease["queue"] == [], lease
        assert call(base, "POST", "/api/scenario", {"name": "contact-angle"}, token=b)[0] == 403
        ok(call(base, "POST", "/api/scenario", {"name": "contact-angle"}, token=a))
    finally:
        stop_server(proc)


def test_the_lease_survives_a_restart(tmp_path):
    extra = ["--data-dir", str(tmp_path / "data")]
    proc, base = start_server(extra=extra)
    try:
        lab = new_token(base, "experimenter", "lab-a")
        ok(call(base, "DELETE", "/api/lease"))
        holder = ok(call(base, "POST", "/api/lease", token=lab))["lease"]["holder"]
    finally:
        stop_server(proc)
    proc, base = start_server(extra=extra, take_lease=False)
    try:
        lease = ok(call(base, "GET", "/api/lease", token=lab))
        assert lease["you"] == "holder" and lease["holder"]["token_id"] == holder["token_id"], lease
        assert lease["holder"]["since"] == holder["since"]
        ok(call(base, "POST", "/api/scenario", {"name": "contact-angle"}, token=lab))
        assert call(base, "POST", "/api/scenario", {"name": "contact-angle"})[0] == 403  # this run's admin: no lease
    finally:
        stop_server(proc)
