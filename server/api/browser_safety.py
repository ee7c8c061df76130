"""What a web browser may do with the server: which Host names it answers (DNS rebinding), which
page origins may open /ws or send state-changing requests, CORS, and the security headers.

Threats (docs/security.md): any web page open in the experimenter's browser can make requests to
the rig, and a page of an attacker's domain can re-resolve that domain to the rig's address (DNS
rebinding), after which the browser treats the rig as same-origin with the attacker's page.
- **Host allow-list.** A rebinding page's requests carry the attacker's name in `Host`, so only
  names on the list are answered (400 otherwise). IP literals are always answered: a browser
  sends an IP in `Host` only when the page itself was loaded from that IP, which no attacker's
  page can be.
- **Origin allow-list.** Browsers send `Origin` on every WebSocket handshake and state-changing
  request; a foreign one is refused (the WebSocket handshake with HTTP 403, before any message,
  a request with 403). No `Origin` (Python, C#, curl clients) is not a browser page and passes on
  to authentication. Allowed: the page's own origin (the `Host` it asked for), an allowed
  host name on the server's port, and `--allow-origin` extras.
- **CORS.** No CORS header at all unless `--allow-origin` lists origins (Starlette's
  CORSMiddleware, for those only, without credentials: tokens travel as Bearer headers).
- **Headers.** A Content-Security-Policy that allows only the rig's own scripts (plus the
  hashes of the pages' inline import maps), framing by the rig's own pages only, no Referer (join and login codes live in
  URL fragments, but a page's query must not leak either), `no-store` on the API.
"""

from __future__ import annotations

import base64
import hashlib
import ipaddress
import re
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import urlsplit

from starlette.middleware.cors import CORSMiddleware
from starlette.responses import JSONResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send

LOOPBACK_HOSTS = ("localhost", "127.0.0.1", "::1")
WILDCARD_ADDRESSES = ("", "0.0.0.0", "::")
SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})
DEFAULT_PORTS = {"http": 80, "ws": 80, "https": 443, "wss": 443}
# FastAPI's interactive API pages load Swagger UI / ReDoc from this CDN with an inline script.
DOCS_PATHS = ("/docs", "/redoc")
_NAME = re.compile(r"^(\*\.)?[a-z0-9_]([a-z0-9_-]*[a-z0-9_])?(\.[a-z0-9_]([a-z0-9_-]*[a-z0-9_])?)*$")
_INLINE_SCRIPT = re.compile(rb"<script(?![^>]*\bsrc=)[^>]*>(.*?)</script>", re.S | re.I)


def host_name(text: str) -> str:
    """A host as compared here: lower case, no trailing dot, IPv6 without brackets. ValueError
    for anything that is not a DNS name, `*.domain`, `*` or an IP literal."""
    name = text.strip().lower().rstrip(".")
    bracketed = name.startswith("[") and name.endswith("]")
    if bracketed:
        name = name[1:-1]
    if not bracketed and (name == "*" or _NAME.match(name)):
        return name
    try:
        ip = ipaddress.ip_address(name)
        if not bracketed or ip.version == 6:  # [brackets] hold only IPv6 literals
            return str(ip)
    except ValueError:
        pass
    raise ValueError(f"{text!r} is not a host name or IP address")


def _is_ip(name: str) -> bool:
    try:
        ipaddress.ip_address(name)
    except ValueError:
        return False
    return True


def split_host_header(value: str | None) -> tuple[str, int | None] | None:
    """`Host` (or an origin's authority) → (host, port or None); None when malformed."""
    if not value or any(c in value for c in "/\\@?# \t"):
        return None
    if value.startswith("["):
        end = value.find("]")
        host, rest = value[1:end], value[end + 1:]
        if end < 0 or (rest and not rest.startswith(":")):
            return None
        port_text = rest[1:] if rest else None
    else:
        host, colon, port_text = value.partition(":")
        port_text = port_text if colon else None
    if port_text is not None and not (port_text.isdigit() and 0 < int(port_text) < 65536):
        return None
    try:
        return host_name(host), (int(port_text) if port_text is not None else None)
    except ValueError:
        return None


def normalize_origin(text: str) -> str:
    """`scheme://host[:port]` as a browser writes it in `Origin` (default port left out)."""
    parts = urlsplit(text.strip())
    if parts.scheme not in ("http", "https") or parts.path not in ("", "/") or parts.query or parts.fragment:
        raise ValueError(f"origin {text!r}: expected http(s)://HOST[:PORT]")
    host_port = split_host_header(parts.netloc)
    if host_port is None or host_port[0] == "*" or host_port[0].startswith("*."):
        raise ValueError(f"origin {text!r}: expected http(s)://HOST[:PORT]")
    host, port = host_port
    shown = f"[{host}]" if ":" in host else host
    if port is None or port == DEFAULT_PORTS[parts.scheme]:
        return f"{parts.scheme}://{shown}"
    return f"{parts.scheme}://{shown}:{port}"


@dataclass(frozen=True)
class BrowserPolicy:
    """The allow-lists (sans-I/O: every decision is a pure function of its arguments)."""

    hosts: frozenset[str]                  # host_name() forms; "*" answers every host
    origins: frozenset[str] = frozenset()  # normalize_origin() forms (--allow-origin)
    port: int | None = None                # the server's port (None: the connection's own)

    @classmethod
    def build(cls, bind_host: str, *, extra_hosts: Iterable[str] = (), extra_origins: Iterable[str] = (),
              cert_names: Iterable[str] = (), names: Iterable[str] = (), port: int | None = None) -> "BrowserPolicy":
        """The default lists (loopback, the bound host, this machine's names, the certificate's
        names) plus the extras. ValueError names a malformed entry."""
        hosts = {*LOOPBACK_HOSTS, *names, *cert_names, *extra_hosts}
        if bind_host not in WILDCARD_ADDRESSES:
            hosts.add(bind_host)
        return cls(hosts=frozenset(host_name(h) for h in hosts),
                   origins=frozenset(normalize_origin(o) for o in extra_origins), port=port)

    def host_allowed(self, host: str) -> bool:
        if "*" in self.hosts or host in self.hosts or _is_ip(host):
            return True
        return any(h.startswith("*.") and host.endswith(h[1:]) for h in self.hosts)

    def _named(self, host: str) -> bool:
        """On the list by name (an IP too, but only one listed: any IP is not enough for an origin)."""
        return host in self.hosts or any(h.startswith("*.") and host.endswith(h[1:]) for h in self.hosts)

    def origin_allowed(self, origin: str, host_header: str | None, server_port: int | None) -> bool:
        """May a page of `origin` talk to this server, asked for by `host_header` on `server_port`?"""
        try:
            origin = normalize_origin(origin)
        except ValueError:
            return False  # "null" (sandboxed frames, file: pages) and anything malformed
        if origin in self.origins:
            return True
        scheme, _, authority = origin.partition("://")
        host, port = split_host_header(authority) or ("", None)
        port = port or DEFAULT_PORTS[scheme]
        asked = split_host_header(host_header)
        if asked is not None and (host, port) == (asked[0], asked[1] or port) and self.host_allowed(host):
            return True  # the page's own origin (same host and port as the request)
        own_port = self.port or server_port
        return self._named(host) and own_port is not None and port == own_port


def inline_script_hashes(pages: Iterable[Path]) -> list[str]:
    """CSP hash sources of the inline scripts (the import maps) of the served pages."""
    out: set[str] = set()
    for page in pages:
        try:
            data = page.read_bytes()
        except OSError:
            continue
        for body in _INLINE_SCRIPT.findall(data):
            out.add("'sha256-%s'" % base64.b64encode(hashlib.sha256(body).digest()).decode())
    return sorted(out)


def content_security_policy(script_hashes: Iterable[str] = ()) -> str:
    return "; ".join([
        "default-src 'self'",
        " ".join(["script-src 'self'", *script_hashes]),
        "style-src 'self' 'unsafe-inline'",   # style attributes only; no script can run through them
        "img-src 'self' data: blob:",
        "connect-src 'self' ws: wss:",       # /ws is ws(s)://the same host; 'self' covers it only in newer browsers
        "object-src 'none'",
        "base-uri 'none'",
        "form-action 'self'",
        "frame-ancestors 'self'",            # the console frames the participant page; no other site may
    ])


# /docs and /redoc load their assets from this server (server/api/web_client.py install_docs);
# ReDoc runs its search in a worker made from a blob: URL
DOCS_CSP = ("default-src 'self'; script-src 'self' 'unsafe-inline'; style-src 'self' 'unsafe-inline'; "
            "img-src 'self' data:; connect-src 'self'; worker-src 'self' blob:; object-src 'none'; "
            "frame-ancestors 'none'")


def security_headers(path: str, csp: str) -> list[tuple[bytes, bytes]]:
    """The headers every HTTP response gets (an existing header of the same name is kept)."""
    headers = [
        (b"content-security-policy", (DOCS_CSP if path in DOCS_PATHS else csp).encode()),
        (b"x-content-type-options", b"nosniff"),
        (b"x-frame-options", b"SAMEORIGIN"),
        (b"referrer-policy", b"no-referrer"),
        (b"cross-origin-opener-policy", b"same-origin"),
        (b"cross-origin-resource-policy", b"same-origin"),
        (b"permissions-policy", b"xr-spatial-tracking=(self), camera=(), microphone=(), geolocation=(), usb=(), "
                                b"serial=(), payment=()"),
    ]
    if path == "/api" or path.startswith("/api/"):
        headers.append((b"cache-control", b"no-store"))
    return headers


class BrowserSafety:
    """Pure-ASGI middleware: Host check, Origin check, CORS (when asked for), security headers."""

    def __init__(self, app: ASGIApp, policy: BrowserPolicy, pages: Iterable[Path] = ()) -> None:
        self.policy = policy
        self.csp = content_security_policy(inline_script_hashes(pages))
        # CORS only for the listed origins; without them, no CORS header is ever sent.
        self.app = (CORSMiddleware(app, allow_origins=sorted(policy.origins), allow_methods=["*"],
                                   allow_headers=["authorization", "content-type"], allow_credentials=False)
                    if policy.origins else app)

    def _headers(self, scope: Scope) -> dict[str, str]:
        return {k.decode("latin-1"): v.decode("latin-1") for k, v in scope.get("headers", ())}

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        headers = self._headers(scope)
        host = split_host_header(headers.get("host"))
        if host is None or not self.policy.host_allowed(host[0]):
            await self._refuse(scope, receive, send, 400, "Invalid host header")
            return
        origin = headers.get("origin")
        checks_origin = scope["type"] == "websocket" or scope["method"] not in SAFE_METHODS
        if checks_origin and origin is not None and not self.policy.origin_allowed(
                origin, headers.get("host"), (scope.get("server") or (None, None))[1]):
            if scope["type"] == "websocket":
                # A close before accept refuses the handshake: the server answers HTTP 403.
                await send({"type": "websocket.close", "code": 1008, "reason": "origin not allowed"})
            else:
                await self._refuse(scope, receive, send, 403, "Origin not allowed")
            return
        if scope["type"] == "websocket":
            await self.app(scope, receive, send)
            return
        extra = security_headers(scope["path"], self.csp)

        async def send_with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                present = {k.lower() for k, _ in message.get("headers", ())}
                message = {**message, "headers": [*message.get("headers", ()),
                                                  *(h for h in extra if h[0] not in present)]}
            await send(message)

        await self.app(scope, receive, send_with_headers)

    async def _refuse(self, scope: Scope, receive: Receive, send: Send, status: int, text: str) -> None:
        if scope["type"] == "websocket" and "websocket.http.response" not in scope.get("extensions", {}):
            await send({"type": "websocket.close", "code": 1008, "reason": text})  # the handshake gets 403
            return
        response = JSONResponse({"detail": text}, status_code=status)  # the body every API error has
        response.raw_headers.extend(security_headers(scope["path"], self.csp))
        await response(scope, receive, send)


def options_for(settings) -> dict:
    """BrowserSafety's arguments as `viestac serve` configures it (server.config.Settings);
    ValueError names a malformed --allow-host/--allow-origin."""
    from server.api.web_client import PAGES
    from server.tls import certificate_names, machine_names

    policy = BrowserPolicy.build(settings.host, extra_hosts=settings.allowed_hosts,
                                 extra_origins=settings.allowed_origins, names=machine_names(),
                                 cert_names=certificate_names(settings.tls_cert) if settings.tls_cert else (),
                                 port=settings.port or None)
    return {"policy": policy, "pages": [settings.web_root / p for p in sorted(PAGES) if p.endswith(".html")]}
