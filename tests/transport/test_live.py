"""A running `viestac serve`: the Host and Origin checks on the wire, the login link it prints,
and HTTPS/WSS with a `viestac tls init` certificate verified against its CA by Python's ssl."""

from __future__ import annotations

import http.client
import re
import ssl

import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from server.auth import open_book
from tests.transport.conftest import get

pytestmark = pytest.mark.slow


def raw_get(served, path: str, host: str) -> int:
    """A request with exactly this Host header (http.client would otherwise write its own)."""
    conn = http.client.HTTPConnection("127.0.0.1", served.port, timeout=5)
    try:
        conn.putrequest("GET", path, skip_host=True)
        conn.putheader("Host", host)
        conn.endheaders()
        return conn.getresponse().status
    finally:
        conn.close()


def ws_url(served) -> str:
    return served.base.replace("http", "ws", 1) + "/ws"


def test_a_foreign_host_header_gets_400(http_server):
    assert raw_get(http_server, "/", "evil.example") == 400
    assert raw_get(http_server, "/api/health", f"evil.example:{http_server.port}") == 400
    assert raw_get(http_server, "/", f"localhost:{http_server.port}") == 200
    assert raw_get(http_server, "/", f"127.0.0.1:{http_server.port}") == 200


def test_a_websocket_handshake_from_a_foreign_origin_is_refused(http_server):
    for origin in ("http://evil.example", f"http://evil.example:{http_server.port}", "null"):
        with pytest.raises(InvalidStatus) as refused:
            connect(ws_url(http_server), origin=origin, open_timeout=5).close()
        assert refused.value.response.status_code == 403, origin
    with pytest.raises(InvalidStatus) as refused:
        connect(ws_url(http_server), additional_headers={"Host": "evil.example"}, open_timeout=5).close()
    assert refused.value.response.status_code in (400, 403)
    # the server's own pages may (the handshake completes; hello and the token come after it)
    connect(ws_url(http_server), origin=http_server.base, open_timeout=5).close()
    connect(ws_url(http_server), open_timeout=5).close()  # no Origin: not a browser page


def test_pages_carry_the_security_headers(http_server):
    status, headers, _ = get(http_server, "/index.html")
    assert status == 200
    assert "frame-ancestors 'self'" in headers["content-security-policy"]
    assert headers["referrer-policy"] == "no-referrer" and headers["x-content-type-options"] == "nosniff"
    assert not [h for h in headers if h.lower().startswith("access-control-")]


def test_the_login_link_is_printed_once_per_start_and_is_a_single_use_admin_code(http_server):
    links = [m for line in http_server.lines
             for m in re.findall(r"(http://127\.0\.0\.1:\d+/console\.html#login=([\w-]+))", line)]
    assert len(links) == 1, http_server.lines
    url, code = links[0]
    assert url.startswith(http_server.base + "/")
    store, book = open_book(http_server.data_dir)  # the database the server reads
    try:
        secret, identity = book.redeem("login", code, token_ttl_s=60)
        assert identity.role == "admin" and book.verify(secret) == identity
        assert book.redeem("login", code, token_ttl_s=60) is None  # single use
    finally:
        store.close()


def test_https_and_wss_verify_against_the_generated_ca(https_server, tls_files):
    assert https_server.base.startswith("https://127.0.0.1:")
    for name in ("localhost", "127.0.0.1"):
        conn = http.client.HTTPSConnection(name, https_server.port, timeout=5, context=https_server.ssl_context())
        conn.request("GET", "/index.html")
        response = conn.getresponse()
        assert response.status == 200 and b"importmap" in response.read()
        conn.close()
    with connect(f"wss://localhost:{https_server.port}/ws", ssl=https_server.ssl_context(),
                 origin=f"https://localhost:{https_server.port}", open_timeout=5):
        pass
    untrusted = ssl.create_default_context()  # the system's CAs do not know the rig's
    with pytest.raises(ssl.SSLCertVerificationError):
        conn = http.client.HTTPSConnection("localhost", https_server.port, timeout=5, context=untrusted)
        conn.request("GET", "/")
    assert any(line.startswith("ViESTac serving") and "wss://" in line for line in https_server.lines)
    assert any(f"https://127.0.0.1:{https_server.port}/console.html#login=" in line for line in https_server.lines)
