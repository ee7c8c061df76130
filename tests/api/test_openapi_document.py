"""The OpenAPI document names every error status a route answers, with the body it has
(server/api/errors.py); the live check that answers match it is test_openapi_fuzz.py."""

from __future__ import annotations

import pytest

from server.app import create_app
from server.config import Settings


@pytest.fixture(scope="module")
def document(tmp_path_factory):
    app = create_app(Settings(data_dir=tmp_path_factory.mktemp("data"), tracker_udp="off"))
    return app.openapi()  # no lifespan: nothing starts


def operations(document):
    for path, methods in document["paths"].items():
        for method, op in methods.items():
            yield f"{method.upper()} {path}", op


def test_every_error_status_has_a_json_body_schema(document):
    for name, op in operations(document):
        for status, response in op["responses"].items():
            if status.startswith(("4", "5")):
                assert response["content"]["application/json"]["schema"], (name, status)


def test_a_422_is_documented_as_either_validation_list_or_sentence(document):
    refs = set()
    for _name, op in operations(document):
        if "422" in op["responses"]:
            schema = op["responses"]["422"]["content"]["application/json"]["schema"]
            refs.add(tuple(sorted(s["$ref"] for s in schema["anyOf"])))
    assert refs == {("#/components/schemas/InvalidRequest", "#/components/schemas/Refusal")}, refs
    detail = document["components"]["schemas"]["Refusal"]["properties"]["detail"]
    assert detail["type"] == "string"


@pytest.mark.parametrize("name, statuses", [
    ("POST /api/scenario", {"400", "404", "409", "422", "503"}),
    ("POST /api/trial", {"400", "409", "422", "503"}),
    ("POST /api/sessions", {"400", "404", "409", "422"}),
    ("POST /api/sessions/{session_id}/trials/{seq}/start", {"403", "404", "409", "422", "503"}),
    ("PUT /api/sessions/{session_id}/notes", {"400", "403", "404", "409", "422"}),
    ("GET /api/state", {"503"}),
])
def test_routes_document_the_statuses_they_answer(document, name, statuses):
    op = dict(operations(document))[name]
    assert statuses <= set(op["responses"]), (name, sorted(op["responses"]))


def test_integers_a_client_sends_are_bounded(document):
    schemas = document["components"]["schemas"]
    for model, field in [("ScenarioRequest", "seed"), ("TrialRequest", "index")]:
        prop = schemas[model]["properties"][field]
        assert prop["minimum"] == 0 and prop["maximum"] == 2**53 - 1, (model, prop)
    plan = dict(operations(document))["GET /api/studies/{study_id}/plan"]
    index = next(p for p in plan["parameters"] if p["name"] == "participant_index")["schema"]
    assert index["minimum"] == 0 and index["maximum"] == 2**53 - 1, index


def test_every_operation_says_who_may_call_it(document):
    from server.auth.policy import POLICY
    for name, op in operations(document):
        rule = POLICY[name]
        assert op["x-viestac-access"] == {"roles": sorted(rule.roles), "lease": rule.lease, "scope": rule.scope}, name
        # the bearer token is optional (an empty requirement beside it) on the public ones only
        assert ({} in op["security"]) == (not rule.roles), name
    ops = dict(operations(document))
    assert ops["GET /api/health"]["security"] == [{}, {"HTTPBearer": []}]
    assert ops["POST /api/scenario"]["x-viestac-access"]["lease"] is True
