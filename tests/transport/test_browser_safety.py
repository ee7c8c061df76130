"""BrowserSafety through the ASGI interface: Host and Origin allow-lists, CORS, security headers."""

from __future__ import annotations

import asyncio
import base64
import hashlib
import re
from pathlib import Path

import httpx
import pytest
from starlette.applications import Starlette
from starlette.responses import PlainTextResponse
from starlette.routing import Route, WebSocketRoute
from starlette.testclient import TestClient, WebSocketDenialResponse
from starlette.websockets import WebSocketDisconnect

from server.api.browser_safety import (BrowserPolicy, BrowserSafety, host_name, normalize_origin,
                                       split_host_header)

WEB = Path(__file__).resolve().parents[2] / "clients" / "web"


async def _ok(request):
    return PlainTextResponse("ok")


async def _ws(websocket):
    await websocket.accept()
    await websocket.send_text("hi")
    await websocket.close()


def make_app(policy: BrowserPolicy, pages=()) -> BrowserSafety:
    inner = Starlette(routes=[Route("/api/x", _ok, methods=["GET", "POST"]), Route("/page", _ok),
                              WebSocketRoute("/ws", _ws)])
    return BrowserSafety(inner, policy, pages=pages)


POLICY = BrowserPolicy.build("127.0.0.1", names=["rig", "rig.local"], extra_hosts=["*.lab.example"], port=8000)


def request(app, method: str, path: str, headers: dict) -> httpx.Response:
    async def go():
        async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app), base_url="http://127.0.0.1:8000") as c:
            return await c.request(method, path, headers=headers)
    return asyncio.run(go())


def test_host_names_are_normalised_and_bad_ones_refused():
    assert host_name("RIG.Local.") == "rig.local"
    assert host_name("[::1]") == host_name("::1") == "::1"
    assert host_name("*.lab.example") == "*.lab.example"
    for bad in ("evil.example/x", "a b", "", "-x", "[zz]"):
        with pytest.raises(ValueError):
            host_name(bad)
    assert split_host_header("[::1]:8000") == ("::1", 8000)
    assert split_host_header("rig:8000") == ("rig", 8000)
    assert split_host_header("rig") == ("rig", None)
    for bad in (None, "", "rig:0", "rig:99999", "rig:x", "a@rig", "[::1", "rig/..", "[::1]x"):
        assert split_host_header(bad) is None, bad


def test_origins_are_normalised():
    assert normalize_origin("HTTP://Rig:80") == "http://rig"
    assert normalize_origin("https://rig:8443/") == "https://rig:8443"
    assert normalize_origin("http://[::1]:8000") == "http://[::1]:8000"
    for bad in ("null", "ftp://rig", "http://rig/path", "http://*.x", "rig:8000"):
        with pytest.raises(ValueError):
            normalize_origin(bad)


def test_hosts_allowed_by_name_wildcard_or_as_an_ip_literal():
    for host in ("localhost", "127.0.0.1", "::1", "rig", "rig.local", "a.lab.example", "192.168.1.20", "fd00::2"):
        assert POLICY.host_allowed(host_name(host)), host
    for host in ("evil.example", "lab.example.evil", "rig.evil", "xlab.example"):
        assert not POLICY.host_allowed(host), host
    assert BrowserPolicy.build("0.0.0.0", extra_hosts=["*"]).host_allowed("anything.example")


def test_origin_must_be_the_page_itself_a_named_host_on_our_port_or_listed():
    p = BrowserPolicy.build("127.0.0.1", names=["rig"], extra_origins=["https://console.lab.example"])
    assert p.origin_allowed("http://127.0.0.1:8000", "127.0.0.1:8000", 8000)    # same origin
    assert p.origin_allowed("http://192.168.1.20:8000", "192.168.1.20:8000", 8000)  # same origin, by IP
    assert p.origin_allowed("http://rig:8000", "127.0.0.1:8000", 8000)          # a named host, our port
    assert p.origin_allowed("https://console.lab.example", "rig:8000", 8000)    # --allow-origin
    assert not p.origin_allowed("http://evil.example:8000", "127.0.0.1:8000", 8000)
    assert not p.origin_allowed("http://rig:9999", "127.0.0.1:8000", 8000)      # another service on the rig
    assert not p.origin_allowed("http://1.2.3.4:8000", "192.168.1.20:8000", 8000)  # an IP is not a name
    assert not p.origin_allowed("null", "127.0.0.1:8000", 8000)
    # a page behind a port forward: its own origin is what the browser asked for
    assert p.origin_allowed("http://localhost:18000", "localhost:18000", 8000)


def test_a_foreign_host_gets_400_for_pages_api_and_websocket():
    app = make_app(POLICY)
    assert request(app, "GET", "/page", {"host": "evil.example:8000"}).status_code == 400
    assert request(app, "GET", "/api/x", {"host": "evil.example"}).status_code == 400
    assert request(app, "GET", "/api/x", {"host": "a@rig"}).status_code == 400
    assert request(app, "GET", "/api/x", {"host": "rig:8000"}).status_code == 200
    client = TestClient(app)
    with pytest.raises(WebSocketDenialResponse) as refused:  # the handshake is denied before it is accepted
        with client.websocket_connect("/ws", headers={"host": "evil.example:8000"}):
            pass
    assert refused.value.status_code == 400
    with client.websocket_connect("/ws", headers={"host": "rig:8000"}) as ws:
        assert ws.receive_text() == "hi"


def test_a_foreign_origin_may_not_open_the_websocket_or_change_state():
    app = make_app(POLICY)
    client = TestClient(app)
    host = {"host": "127.0.0.1:8000"}
    with pytest.raises(WebSocketDisconnect) as refused:  # closed before accept (uvicorn answers HTTP 403)
        with client.websocket_connect("/ws", headers={**host, "origin": "http://evil.example"}):
            pass
    assert refused.value.code == 1008
    with client.websocket_connect("/ws", headers={**host, "origin": "http://127.0.0.1:8000"}) as ws:
        assert ws.receive_text() == "hi"
    with client.websocket_connect("/ws", headers=host) as ws:  # no Origin: not a browser page; the token decides
        assert ws.receive_text() == "hi"
    assert request(app, "POST", "/api/x", {"host": "127.0.0.1:8000", "origin": "http://evil.example"}).status_code == 403
    assert request(app, "POST", "/api/x", {"host": "127.0.0.1:8000", "origin": "null"}).status_code == 403
    assert request(app, "POST", "/api/x", {"host": "127.0.0.1:8000", "origin": "http://127.0.0.1:8000"}).status_code == 200
    # a read from a foreign page is answered, but without CORS headers the browser hides it
    read = request(app, "GET", "/api/x", {"host": "127.0.0.1:8000", "origin": "http://evil.example"})
    assert read.status_code == 200 and not [h for h in read.headers if h.startswith("access-control-")]


def test_cors_only_for_listed_origins():
    app = make_app(BrowserPolicy.build("127.0.0.1", extra_origins=["https://console.lab.example"]))
    pre = request(app, "OPTIONS", "/api/x", {"host": "127.0.0.1:8000", "origin": "https://console.lab.example",
                                             "access-control-request-method": "POST",
                                             "access-control-request-headers": "authorization, content-type"})
    assert pre.status_code == 200
    assert pre.headers["access-control-allow-origin"] == "https://console.lab.example"
    assert "access-control-allow-credentials" not in pre.headers
    evil = request(app, "OPTIONS", "/api/x", {"host": "127.0.0.1:8000", "origin": "http://evil.example",
                                              "access-control-request-method": "POST"})
    assert "access-control-allow-origin" not in evil.headers
    plain = make_app(POLICY)
    pre = request(plain, "OPTIONS", "/api/x", {"host": "127.0.0.1:8000", "origin": "https://console.lab.example",
                                               "access-control-request-method": "POST"})
    assert not [h for h in pre.headers if h.startswith("access-control-")]


def test_security_headers_on_pages_api_and_refusals():
    app = make_app(POLICY)
    page = request(app, "GET", "/page", {"host": "127.0.0.1:8000"})
    csp = page.headers["content-security-policy"]
    assert "default-src 'self'" in csp and "frame-ancestors 'self'" in csp and "connect-src 'self' ws: wss:" in csp
    assert "'unsafe-inline'" not in csp.split("script-src", 1)[1].split(";")[0]
    assert page.headers["x-content-type-options"] == "nosniff"
    assert page.headers["referrer-policy"] == "no-referrer"
    assert "xr-spatial-tracking=(self)" in page.headers["permissions-policy"]
    assert "cache-control" not in page.headers
    assert request(app, "GET", "/api/x", {"host": "127.0.0.1:8000"}).headers["cache-control"] == "no-store"
    refused = request(app, "GET", "/page", {"host": "evil.example"})
    assert refused.headers["x-frame-options"] == "SAMEORIGIN" and "content-security-policy" in refused.headers


def test_the_pages_inline_import_maps_are_allowed_by_hash(tmp_path):
    pages = [WEB / "index.html", WEB / "console.html"]
    app = make_app(POLICY, pages=pages)
    csp = request(app, "GET", "/page", {"host": "127.0.0.1:8000"}).headers["content-security-policy"]
    for page in pages:
        maps = re.findall(rb'<script type="importmap">(.*?)</script>', page.read_bytes(), re.S)
        assert maps, page
        for body in maps:
            assert "'sha256-%s'" % base64.b64encode(hashlib.sha256(body).digest()).decode() in csp
    changed = tmp_path / "index.html"
    changed.write_text('<script type="importmap">{"imports": {"x": "https://evil.example/x.js"}}</script>')
    other = make_app(POLICY, pages=[changed])
    assert request(other, "GET", "/page", {"host": "127.0.0.1:8000"}).headers["content-security-policy"] != csp
