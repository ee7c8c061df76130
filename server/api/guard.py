"""The REST guard: every /api operation is checked against the declared policy before its handler
runs (server/auth/policy.py).

`guard` is the dependency of every /api router (app.py). It names the operation as /openapi.json
does ("POST /api/scenario"), looks its Rule up in POLICY and refuses an operation without one
(fail closed: a new endpoint is unusable until it is declared, and the policy test fails). Then:
the bearer token (401; 429 while failed attempts with that token's prefix are throttled), role and
lease (403, `decide`), a running trial of another lab or session (409, `decide`), the token's
request budget (429), and the lease holder's renewal. The caller's
Identity is left in `request.state.identity` for handlers that scope by site.

`AuditTrail` writes one audit row for every state-changing /api request once its answer is known
(who, the operation, its path, the status), off the event loop.

Everything here runs on the event loop's thread, as the lease tick does: the Lease is not shared
with worker threads.
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from typing import Annotated

from fastapi import Depends, HTTPException, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from server.auth import AccessControl, Unauthorized
from server.auth.identity import CONTROLLERS, Identity
from server.auth.policy import POLICY, decide
from server.auth.ratelimit import TokenBucket

log = logging.getLogger("viestac.guard")

# Requests a token may make, sustained and in a burst: far above a person at a console, and above a
# scripted experimenter polling every 10 ms from several tasks (the live thesis study); a runaway
# or leaked token still cannot take the server's whole REST capacity.
TOKEN_RATE_PER_S = 500.0
TOKEN_BURST = 1000
SAFE_METHODS = ("GET", "HEAD", "OPTIONS")

bearer = HTTPBearer(auto_error=False, description="a token from `viestac token create`, a login link or a join "
                                                   "link")
BearerDep = Annotated[HTTPAuthorizationCredentials | None, Depends(bearer)]


def operation(request: Request) -> str:
    """The operation as /openapi.json names it: METHOD and the route's path template."""
    route = request.scope.get("route")
    return f"{request.method} {getattr(route, 'path', request.url.path)}"


def peer(request: Request) -> str:
    return request.client.host if request.client is not None else "unknown"


def _unauthorized(message: str) -> HTTPException:
    return HTTPException(401, message, headers={"WWW-Authenticate": "Bearer"})


def too_many(message: str, retry_after_s: float) -> HTTPException:
    return HTTPException(429, message, headers={"Retry-After": str(max(1, math.ceil(retry_after_s)))})


class _Budgets:
    """Per-token request budgets (one set per app)."""

    def __init__(self) -> None:
        self.buckets: dict[str, TokenBucket] = {}

    def take(self, token_id: str, now_ns: int) -> bool:
        bucket = self.buckets.get(token_id)
        if bucket is None:
            bucket = self.buckets[token_id] = TokenBucket(TOKEN_RATE_PER_S, TOKEN_BURST, now_ns)
        return bucket.take(now_ns)


def _budgets(request: Request) -> _Budgets:
    state = request.app.state
    if not hasattr(state, "rest_budgets"):
        state.rest_budgets = _Budgets()
    return state.rest_budgets


async def guard(request: Request, credentials: BearerDep) -> Identity | None:
    """Allow the request or raise the refusal (401, 403, 429). Returns the caller (None: anonymous)."""
    access: AccessControl = request.app.state.access
    key = operation(request)
    request.state.operation = key
    request.state.identity = None
    rule = POLICY.get(key)
    if rule is None:  # fail closed
        log.error("no access policy for %s: refused", key)
        raise HTTPException(403, f"{key} has no declared access policy; refused")
    who = None
    if credentials is not None:
        try:
            who = access.authenticate(credentials.credentials, peer(request))
        except Unauthorized as exc:
            if exc.retry_after_s:
                raise too_many(exc.message, exc.retry_after_s) from None
            if rule.roles:
                raise _unauthorized(exc.message) from None
            # a public operation answers anyone; a bad token only makes the caller anonymous
    request.state.identity = who
    refusal = decide(rule, who, access.lease, access.running() if rule.recorded else None)
    if refusal is not None:
        status, reason = refusal
        raise _unauthorized(reason) if status == 401 else HTTPException(status, reason)
    if who is None:
        return None
    if not _budgets(request).take(who.token_id, time.monotonic_ns()):
        raise too_many(f"token {who.token_id} is over its {TOKEN_RATE_PER_S:g} requests a second", 1.0)
    if who.role in CONTROLLERS:  # any authorised call of the holder (or a queued one) keeps its place
        access.renew(who)
    return who


def identity(request: Request) -> Identity | None:
    """The caller the guard let through (None: anonymous on a public operation)."""
    return getattr(request.state, "identity", None)


def site_scope(request: Request) -> str | None:
    """Whose sessions the caller sees: None for the admin (every site), else its own site ('' when
    an experimenter has none: then it sees none but those it made)."""
    who = identity(request)
    if who is not None and who.role == "admin":
        return None
    return (who.site or "") if who is not None else ""


class AuditTrail:
    """ASGI middleware: one audit row per state-changing /api request, with its status."""

    def __init__(self, app) -> None:
        self.app = app

    async def __call__(self, scope, receive, send) -> None:
        if scope["type"] != "http" or scope["method"] in SAFE_METHODS or not scope["path"].startswith("/api/"):
            await self.app(scope, receive, send)
            return
        status = 500

        async def send_status(message) -> None:
            nonlocal status
            if message["type"] == "http.response.start":
                status = message["status"]
            await send(message)

        try:
            await self.app(scope, receive, send_status)
        finally:
            await self._record(scope, status)

    @staticmethod
    async def _record(scope, status: int) -> None:
        state = scope.get("state") or {}
        action = state.get("operation")
        access = getattr(scope["app"].state, "access", None) if "app" in scope else None
        if action is None or access is None:  # not an operation of ours (404 of an unknown path)
            return
        params = scope.get("path_params") or {}
        result = "ok" if status < 400 else f"refused {status}" if status in (401, 403, 404, 409, 429) else f"error {status}"
        who, session_id = state.get("identity"), params.get("session_id") or state.get("audit_session_id")
        experiment = getattr(scope["app"].state, "experiment", None)

        def write() -> None:
            site = None  # the actor's own; an admin's action on a lab's session is that lab's to see too
            if session_id is not None and experiment is not None and (who is None or who.role == "admin"):
                try:
                    site = experiment.site_of(session_id)
                except ValueError:  # no such session
                    pass
            access.audit.record(who, action, scope["path"], result, session_id=session_id, site=site)

        try:
            await asyncio.to_thread(write)
        except Exception:  # the audit must not turn an answered request into a crash
            log.exception("could not write the audit row of %s", action)


def describe_access(document: dict) -> dict:
    """Write each operation's POLICY rule into the OpenAPI document, so a client reads who may
    call it: `x-viestac-access` {roles, lease, scope}; on the public ones the bearer scheme is optional
    (an empty requirement beside it: no token, or a bad one, makes the caller anonymous)."""
    for path, methods in document.get("paths", {}).items():
        for method, op in methods.items():
            rule = POLICY.get(f"{method.upper()} {path}")
            if rule is None:  # the guard refuses it; the matrix test names it
                continue
            op["x-viestac-access"] = {"roles": sorted(rule.roles), "lease": rule.lease, "scope": rule.scope}
            if not rule.roles:
                op["security"] = [{}, *op.get("security", [])]
    return document


def install_access_doc(app) -> None:
    """app.openapi() with describe_access applied once, on the cached document."""
    build = app.openapi

    def openapi() -> dict:
        if app.openapi_schema is None:
            app.openapi_schema = describe_access(build())
        return app.openapi_schema

    app.openapi = openapi
