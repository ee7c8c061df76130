"""Integers a REST client sends are bounded at the edge: out of range is a 422 naming the field in
FastAPI's validation shape, never a 500 from msgpack or SQLite deep inside (issue: REST 500s found
by schemathesis). Against a real server, since those 500s came from the loop's mailbox and the
database, which a fake hub would not reach."""

from __future__ import annotations

import json
import urllib.error
import urllib.request

import pytest

from server.api.errors import MAX_INT
from tests.live_server import auth_headers, start_server, stop_server

STUDY = "thesis-2021"


@pytest.fixture(scope="module")
def base():
    proc, url = start_server()
    try:
        yield url
    finally:
        stop_server(proc)


def call(base: str, method: str, path: str, body: dict | None = None) -> tuple[int, object]:
    data = json.dumps(body).encode() if body is not None else None
    request = urllib.request.Request(base + path, data=data, method=method,
                                     headers={"Content-Type": "application/json", **auth_headers(base)})
    try:
        with urllib.request.urlopen(request, timeout=10) as response:
            return response.status, json.loads(response.read())
    except urllib.error.HTTPError as exc:
        return exc.code, json.loads(exc.read() or b"null")


def assert_field_refused(answer: tuple[int, object], field: str) -> None:
    status, body = answer
    assert status == 422, answer
    assert isinstance(body, dict) and isinstance(body["detail"], list), body
    assert any(err["loc"][-1] == field and err["msg"] and err["type"] for err in body["detail"]), body


def test_plan_with_a_negative_participant_index_is_refused(base):
    assert_field_refused(call(base, "GET", f"/api/studies/{STUDY}/plan?participant_index=-1"), "participant_index")
    assert_field_refused(call(base, "GET", f"/api/studies/{STUDY}/plan?participant_index={2**64}"),
                         "participant_index")
    status, plan = call(base, "GET", f"/api/studies/{STUDY}/plan?participant_index=1")
    assert status == 200 and plan and plan[0]["seq"] == 0


def test_session_with_a_huge_participant_index_is_refused(base):
    body = {"study": STUDY, "participant": "P900", "experimenter": "ann", "participant_index": 2**73}
    assert_field_refused(call(base, "POST", "/api/sessions", body), "participant_index")
    status, sessions = call(base, "GET", "/api/sessions")
    assert status == 200 and not [s for s in sessions if s.get("participant") == "P900"], sessions
    status, created = call(base, "POST", "/api/sessions", {**body, "participant_index": MAX_INT})
    assert status == 201 and created["token"], created


def test_scenario_with_a_huge_seed_is_refused(base):
    assert_field_refused(call(base, "POST", "/api/scenario", {"name": "contact-angle", "seed": 2**64}), "seed")
    status, info = call(base, "POST", "/api/scenario", {"name": "contact-angle", "seed": MAX_INT})
    assert status == 200, info


def test_trial_with_a_huge_index_is_refused(base):
    assert_field_refused(call(base, "POST", "/api/trial", {"phase": "main", "index": 2**64}), "index")


def test_trial_seq_in_a_path_is_bounded(base):
    assert_field_refused(call(base, "POST", f"/api/sessions/x/trials/{2**64}/start"), "seq")
    status, body = call(base, "POST", "/api/sessions/x/trials/0/start")
    assert status == 403 and isinstance(body["detail"], str), body  # a refusal in words: no token
