"""`viestac token create|list|revoke|login-link` on a data directory."""

from __future__ import annotations

import json

import pytest

from server.auth import AccessControl, Unauthorized
from server.cli import _ttl_s, main


def _run(capsys, *argv) -> tuple[int, str, str]:
    rc = main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


def test_create_list_revoke_while_a_server_holds_the_file(tmp_path, capsys):
    server = AccessControl.open(tmp_path)  # a running server on the same data directory
    rc, out, err = _run(capsys, "token", "create", "--role", "experimenter", "--site", "lab-a", "--label", "Ada",
                        "--ttl", "12h", "--data-dir", str(tmp_path))
    secret = out.strip()
    assert rc == 0 and len(secret) >= 43 and "lab-a" in err
    who = server.authenticate(secret, "127.0.0.1")
    assert (who.role, who.site, who.label) == ("experimenter", "lab-a", "Ada")
    assert who.expires_at == pytest.approx(who_created(server, who.token_id) + 12 * 3600)
    rc, out, _ = _run(capsys, "token", "list", "--json", "--data-dir", str(tmp_path))
    rows = json.loads(out)
    assert [(r["token_id"], r["active"]) for r in rows] == [(who.token_id, True)]
    assert secret not in out
    rc, out, _ = _run(capsys, "token", "revoke", who.token_id, "--data-dir", str(tmp_path))
    assert rc == 0
    with pytest.raises(Unauthorized):
        server.authenticate(secret, "127.0.0.1")
    rc, _, err = _run(capsys, "token", "revoke", who.token_id, "--data-dir", str(tmp_path))
    assert rc == 1 and "no active token" in err
    server.close()


def who_created(access: AccessControl, token_id: str) -> float:
    return next(r["created_at"] for r in access.book.list() if r["token_id"] == token_id)


def test_create_json_and_refusals(tmp_path, capsys):
    rc, out, _ = _run(capsys, "token", "create", "--role", "admin", "--ttl", "none", "--json", "--data-dir", str(tmp_path))
    body = json.loads(out)
    assert rc == 0 and body["identity"]["role"] == "admin" and body["identity"]["expires_at"] is None
    rc, _, err = _run(capsys, "token", "create", "--role", "experimenter", "--data-dir", str(tmp_path))
    assert rc == 2 and "needs a site" in err


def test_login_link_is_a_single_use_admin_code(tmp_path, capsys):
    rc, out, _ = _run(capsys, "token", "login-link", "--url", "http://rig.local:8000/", "--data-dir", str(tmp_path))
    url = out.strip()
    assert rc == 0 and url.startswith("http://rig.local:8000/console.html#login=")
    code = url.split("#login=", 1)[1]
    access = AccessControl.open(tmp_path)
    secret, who = access.exchange("login", code, "127.0.0.1", token_ttl_s=3600)
    assert who.role == "admin" and access.authenticate(secret, "127.0.0.1") == who
    with pytest.raises(Unauthorized):
        access.exchange("login", code, "127.0.0.1", token_ttl_s=3600)
    access.close()


@pytest.mark.parametrize("text,seconds", [("30d", 30 * 86400), ("12h", 43200), ("45m", 2700), ("90s", 90),
                                          ("1.5h", 5400), ("none", None)])
def test_ttl_parsing(text, seconds):
    assert _ttl_s(text) == seconds


@pytest.mark.parametrize("text", ["", "3", "3x", "-1d", "0h", "d"])
def test_ttl_refused(text):
    with pytest.raises(ValueError):
        _ttl_s(text)
