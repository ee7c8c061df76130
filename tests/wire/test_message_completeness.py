"""Every message declared in server/wire/schema.py is complete: its table in docs/protocol.md, a
test vector (tests/vectors/messages.json), and either a row in the access policy (a client →
server message: server/auth/policy.py) or a handler in both clients (a server → client message:
the browser's `Connection._onMessage`, the C# client's `Protocol.Parse` and `ViestacSession.Dispatch`).
A new message fails here until each is there; docs/architecture.md "How to add things"."""

import json
import re
from pathlib import Path

import pytest

from server.auth.policy import POLICY
from server.wire import messages, schema
from server.wire.doc import DOC, doc_blocks
from server.wire.schema import MESSAGES, PROTOCOL_MINOR

ROOT = Path(__file__).resolve().parents[2]
VECTORS = ROOT / "tests" / "vectors" / "messages.json"
WEB_CONNECTION = ROOT / "clients" / "web" / "src" / "connection.js"
CS_PROTOCOL = ROOT / "clients" / "unity" / "Runtime" / "Protocol.cs"
CS_SESSION = ROOT / "clients" / "unity" / "Runtime" / "Session.cs"


def _body(text: str, start: str, end: str) -> str:
    """The text from the line with `start` to the next line with `end` (a method's body)."""
    head = text.index(start)
    return text[head:text.index(end, head + len(start))]


def web_handled() -> set[str]:
    switch = _body(WEB_CONNECTION.read_text(), "_onMessage(ws, data)", "_onClose(ws, ev)")
    return set(re.findall(r"case '(\w+)':", switch))


def cs_parsed() -> set[str]:
    parse = _body(CS_PROTOCOL.read_text(), "public static ServerMessage Parse(", "public static ServerMessage Decode(")
    return set(re.findall(r'case "(\w+)":', parse))


def cs_dispatched() -> set[str]:
    dispatch = _body(CS_SESSION.read_text(), "void Dispatch(Inbound item)", "// ---- sending")
    return {name.lower() for name in re.findall(r"case MessageType\.(\w+):", dispatch)}


def missing_parts(name: str) -> list[str]:
    message = MESSAGES[name]
    missing = []
    if f"message {name}" not in doc_blocks(DOC.read_text(encoding="utf-8")):
        missing.append(f"its table in docs/protocol.md (<!-- generated: message {name} -->)")
    if not any(v["type"] == name for v in json.loads(VECTORS.read_text())["vectors"]):
        missing.append("a vector in tests/vectors/messages.json (tests/vectors/make_vectors.py)")
    if message.direction == "client_to_server":
        if f"ws:{name}" not in POLICY:
            missing.append(f"its row ws:{name} in server/auth/policy.py POLICY")
    else:
        if name not in web_handled():
            missing.append("a case in clients/web/src/connection.js Connection._onMessage")
        if name not in cs_parsed():
            missing.append("a case in clients/unity/Runtime/Protocol.cs Protocol.Parse")
        if name not in cs_dispatched():
            missing.append("a case in clients/unity/Runtime/Session.cs ViestacSession.Dispatch")
    return missing


@pytest.mark.parametrize("name", sorted(MESSAGES))
def test_every_declared_message_is_complete(name):
    assert missing_parts(name) == [], f"message {name!r} lacks: " + "; ".join(missing_parts(name))


def test_the_checks_see_the_handlers_they_look_for():
    """The parsers above find what is there (an empty set would pass nothing, not everything)."""
    assert {"welcome", "scene", "state", "error"} <= web_handled() & cs_parsed() & cs_dispatched()


def test_a_missing_handler_is_named(monkeypatch):
    monkeypatch.setattr(f"{__name__}.web_handled", lambda: {"welcome", "scene", "state", "error", "health", "lease"})
    assert missing_parts("ask") == ["a case in clients/web/src/connection.js Connection._onMessage"]


@pytest.mark.parametrize("module", [schema, messages])
def test_docstrings_name_the_current_protocol_version(module):
    assert module.__doc__.startswith(f"Protocol v1.{PROTOCOL_MINOR}")
