"""REST routes of access control: log in with a code, who am I, the control lease, participant join
links, the audit log and (admin) tokens. Thin: the guard (server/api/guard.py) has checked role,
site and lease before any handler here runs; the logic lives in server/auth/.

`async def` handlers: they run on the event loop's thread, the only one that touches the Lease
(the lease tick and the guard run there too). Study sessions are looked up on a worker thread.
"""

from __future__ import annotations

import asyncio
import io
import secrets
import time
from typing import Annotated, Literal

from fastapi import APIRouter, Depends, HTTPException, Path, Query, Request
from pydantic import BaseModel, Field

from server.api.errors import errors
from server.api.guard import identity, peer, site_scope, too_many
from server.auth import AccessControl, Unauthorized
from server.auth.identity import ROLES, Identity
from server.experiment.engine import NotFound

router = APIRouter(prefix="/api", tags=["access"])

LOGIN_TOKEN_TTL_S = 30 * 86400.0    # an admin token a login link gives: a month, revocable
JOIN_TOKEN_TTL_S = 12 * 3600.0      # a participant's token: one session's day
JOIN_LINK_TTL_S = 15 * 60.0         # a join link must be used soon (it is single use anyway)
MAX_TTL_S = 366 * 86400.0


def get_access(request: Request) -> AccessControl:
    return request.app.state.access


AccessDep = Annotated[AccessControl, Depends(get_access)]


def caller(request: Request) -> Identity:
    who = identity(request)
    if who is None:  # only on operations the policy declares public, which do not use this
        raise HTTPException(401, "this needs a token", headers={"WWW-Authenticate": "Bearer"})
    return who


CallerDep = Annotated[Identity, Depends(caller)]


class CodeRequest(BaseModel):
    code: str = Field(min_length=1, max_length=200, description="the code of a login or join link (after #login= "
                                                                 "or #join=)")


class HandOver(BaseModel):
    token_id: str = Field(min_length=1, max_length=64, description="a queued token's id (GET /api/lease)")


class JoinLinkRequest(BaseModel):
    session_id: str | None = Field(None, max_length=64, description="a study session of your site, or null for free "
                                                                     "exploration (a fresh id)")
    ttl_s: float = Field(JOIN_LINK_TTL_S, ge=10, le=86400, description="how long the link may be used")


class TokenCreate(BaseModel):
    role: Literal[ROLES]  # type: ignore[valid-type]
    site: str | None = Field(None, min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.-]+$")
    label: str = Field("", max_length=100)
    ttl_s: float | None = Field(None, gt=0, le=MAX_TTL_S, description="seconds until it expires (null: never)")


# -- logging in -----------------------------------------------------------------------------------
def _redeem(access: AccessControl, request: Request, kind: str, code: str, token_ttl_s: float) -> dict:
    """A single-use code for a token; failures per code prefix are throttled (429 with Retry-After)."""
    try:
        token, ident = access.exchange(kind, code, peer(request), token_ttl_s=token_ttl_s)
    except Unauthorized as exc:
        if exc.retry_after_s:
            raise too_many(exc.message, exc.retry_after_s) from None
        raise HTTPException(401, exc.message, headers={"WWW-Authenticate": "Bearer"}) from None
    request.state.identity = ident  # the audit row names who came in
    return {"token": token, "identity": ident.to_dict()}


@router.post("/auth/login", responses=errors(400, 401, 422, 429), summary="Exchange a login link's code (printed by the "
                                                                      "server at start) for an admin token")
async def login(body: CodeRequest, request: Request, access: AccessDep) -> dict:
    return _redeem(access, request, "login", body.code, LOGIN_TOKEN_TTL_S)


@router.post("/auth/join", responses=errors(400, 401, 422, 429), summary="Exchange a participant join link's code for the "
                                                                     "participant's token of that session")
async def join(body: CodeRequest, request: Request, access: AccessDep) -> dict:
    return _redeem(access, request, "join", body.code, JOIN_TOKEN_TTL_S)


@router.get("/auth/me", summary="The identity of this token (role, site, session; never the secret)")
async def me(who: CallerDep) -> dict:
    return who.to_dict()


# -- the control lease ----------------------------------------------------------------------------
def _lease_view(access: AccessControl, who: Identity) -> dict:
    snapshot = access.lease.snapshot()
    holder = snapshot.get("holder")
    queued = next((q for q in snapshot.get("queue", ()) if q["token_id"] == who.token_id), None)
    you = "holder" if holder and holder["token_id"] == who.token_id else "queued" if queued else "none"
    return {**snapshot, "you": you, "position": queued["position"] if queued else None}


@router.get("/lease", summary="Who holds the control lease, the queue, the open participant session, and you")
async def lease(who: CallerDep, access: AccessDep) -> dict:
    return _lease_view(access, who)


@router.post("/lease", summary="Request the control lease: granted at once, or queued with a position")
async def request_lease(who: CallerDep, access: AccessDep) -> dict:
    answer = access.lease.request(who)
    access.lease_changed()
    return {"status": answer["status"], "position": answer.get("position"), "lease": _lease_view(access, who)}


@router.post("/lease/renew", responses=errors(409), summary="Keep the lease (or your place in the queue) alive; "
                                                            "a quiet holder loses it after the lease's ttl_s")
async def renew_lease(who: CallerDep, access: AccessDep) -> dict:
    if not access.lease.renew(who):
        raise HTTPException(409, "you neither hold the lease nor wait for it; request it first")
    access.lease_changed()
    return {"lease": _lease_view(access, who)}


@router.delete("/lease", responses=errors(409), summary="Release the lease (the next in the queue gets it) or leave "
                                                        "the queue")
async def release_lease(who: CallerDep, access: AccessDep) -> dict:
    if not access.lease.release(who):
        raise HTTPException(409, "you neither hold the lease nor wait for it")
    access.lease_changed()
    return {"lease": _lease_view(access, who)}


@router.post("/lease/handover", responses=errors(400, 409, 422), summary="Hand the lease to a token in the queue")
async def hand_over(body: HandOver, who: CallerDep, access: AccessDep) -> dict:
    try:
        access.lease.hand_over(who, body.token_id)
    except (ValueError, PermissionError) as exc:
        raise HTTPException(409, str(exc) or "only the holder can hand the lease to a queued token") from None
    access.lease_changed()
    return {"lease": _lease_view(access, who)}


@router.post("/lease/force-release", summary="Take the lease from its holder (admin); the next in the queue gets it")
async def force_release(who: CallerDep, access: AccessDep) -> dict:
    released = access.lease.force_release()
    if released:
        access.lease_changed()
    return {"released": released, "lease": _lease_view(access, who)}


# -- participant join links -----------------------------------------------------------------------
def qr_svg(text: str) -> str:
    """The link as a QR code (SVG), for a headset's camera."""
    import qrcode
    import qrcode.image.svg

    image = qrcode.make(text, image_factory=qrcode.image.svg.SvgPathImage)
    out = io.BytesIO()
    image.save(out)
    return out.getvalue().decode()


@router.post("/join-links", status_code=201, responses=errors(400, 404, 409, 422), summary=
             "A single-use participant join link (and its QR code) for a study session of your site, or for free "
             "exploration; the lease holder opens that session for participants")
async def join_link(body: JoinLinkRequest, request: Request, who: CallerDep, access: AccessDep) -> dict:
    if body.session_id is None:
        session_id, site = f"free-{secrets.token_hex(4)}", who.site
    else:
        experiment = request.app.state.experiment
        try:
            await asyncio.to_thread(experiment.session, body.session_id, site_scope(request))
            site = await asyncio.to_thread(experiment.site_of, body.session_id)
        except NotFound as exc:
            raise HTTPException(404, str(exc)) from None
        session_id = body.session_id
    running = access.running()
    if running is not None and running.session != session_id:  # its participant would be locked out of it
        lab = f"lab {running.site}" if running.site else "the admin"
        raise HTTPException(409, f"a trial of {lab} is being recorded: a join link for another session would close "
                                 f"that trial's participant session; finish or abort the trial first")
    try:
        access.lease.open_session(who, session_id)
    except PermissionError as exc:
        raise HTTPException(409, str(exc) or "only the lease holder opens a participant session") from None
    access.lease_changed()
    code = access.book.create_code("join", role="participant", site=site, session=session_id, ttl_s=body.ttl_s,
                                   created_by=who.token_id)
    url = f"{str(request.base_url).rstrip('/')}/index.html?role=participant#join={code}"
    return {"url": url, "expires_at": time.time() + body.ttl_s, "session": session_id, "qr_svg": qr_svg(url)}


# -- the audit log --------------------------------------------------------------------------------
@router.get("/audit", responses=errors(422), summary="Control actions, newest first (admin: every site; an "
                                                     "experimenter: its own site)")
async def audit(request: Request, access: AccessDep,
                session_id: str | None = Query(None, max_length=64, description="only this session's actions"),
                limit: int = Query(200, ge=1, le=1000)) -> list[dict]:
    return await asyncio.to_thread(access.audit.rows, site=site_scope(request), session_id=session_id, limit=limit)


# -- tokens (admin) -------------------------------------------------------------------------------
@router.get("/tokens", summary="Every token: id, role, site, label, expiry, revocation (never a secret)")
async def tokens(access: AccessDep) -> list[dict]:
    return await asyncio.to_thread(access.book.list)


@router.post("/tokens", status_code=201, responses=errors(400, 422), summary="A new token; its secret is shown only in "
                                                                        "this answer")
async def create_token(body: TokenCreate, who: CallerDep, access: AccessDep) -> dict:
    if body.role == "experimenter" and body.site is None:
        raise HTTPException(422, "an experimenter token needs a site (its lab)")
    if body.role == "participant":
        raise HTTPException(422, "a participant token comes from a join link (POST /api/join-links)")
    try:
        token, ident = access.book.create(body.role, body.site, label=body.label, ttl_s=body.ttl_s,
                                          created_by=who.token_id)
    except ValueError as exc:
        raise HTTPException(422, str(exc)) from None
    return {"token": token, "identity": ident.to_dict()}


@router.delete("/tokens/{token_id}", responses=errors(404, 422), summary="Revoke a token at once (it also leaves the "
                                                                        "lease)")
async def revoke_token(token_id: Annotated[str, Path(max_length=64, description="the token's id (GET /api/tokens)")],
                       access: AccessDep) -> dict:
    if not access.revoke(token_id):
        raise HTTPException(404, f"no active token {token_id!r}")
    return {"revoked": token_id}
