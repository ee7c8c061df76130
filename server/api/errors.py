"""The REST error model, declared once so the OpenAPI document says what the answers are.

Every error answer is a JSON object with a `detail`:
- 400, 401, 403, 404, 409, 429, 503: `{"detail": "<a sentence a person can act on>"}` (`Refusal`);
- 422: either FastAPI's validation list (`{"detail": [{"loc", "msg", "type", ...}]}`, a field
  failed its declared type or bounds) or a sentence (`Refusal`: the value passed its declared
  type but the scenario, study or lifecycle refuses it, e.g. an unknown trial parameter).

Every /api operation can also answer 401, 403 and 429 from the access guard (server/api/guard.py):
`GUARD_ERRORS` is added to each router in app.py, so the document says so for all of them.

Routes list the statuses they can answer with `responses=errors(...)`; integers that travel to
the loop, the clients or SQLite are bounded with `MAX_INT` at the edge, so an out-of-range
number is a 422, never a 500 from deep inside.
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel

from server.wire.schema import MAX_SAFE_INT

# Integers a client may send: JavaScript-safe like every integer on the wire (docs/protocol.md),
# which also keeps them inside msgpack's and SQLite's 64-bit integers.
MAX_INT = MAX_SAFE_INT


class Refusal(BaseModel):
    """A request the server understood and refused, with the reason in words."""
    detail: str


class FieldError(BaseModel):
    """One field that failed its declared type or bounds (FastAPI's validation error)."""
    loc: list[str | int]
    msg: str
    type: str
    input: Any = None
    ctx: dict[str, Any] | None = None


class InvalidRequest(BaseModel):
    """The request failed the declared schema; one entry per failing field."""
    detail: list[FieldError]


_DESCRIPTIONS = {
    400: "The body could not be read (not JSON text in UTF-8)",
    401: "No token, or an unknown, expired or revoked one (Authorization: Bearer TOKEN; docs/security.md)",
    403: "Not allowed: the token's role, site or the control lease does not permit it, or the session's control "
         "token (X-Control-Token) is missing or not the current one",
    404: "No such scenario, study, session (or one of another site), trial or question",
    409: "Refused in the current state (a device cannot show the scenario, a stale trial, a lifecycle step "
         "out of order)",
    422: "A field failed its declared type or bounds (a list of {loc, msg, type}), or a value the scenario "
         "or study refuses (a sentence)",
    429: "Too many requests with this token, or too many failed logins from this address; see Retry-After",
    503: "The loop or the device host is not ready (not started yet, restarting, or its queue is full)",
}


def errors(*codes: int) -> dict[int | str, dict[str, Any]]:
    """The `responses=` of a route that can answer with these error statuses."""
    return {code: {"model": InvalidRequest | Refusal if code == 422 else Refusal,
                   "description": _DESCRIPTIONS[code], **(_RETRY_AFTER if code == 429 else {})} for code in codes}


_RETRY_AFTER = {"headers": {"Retry-After": {"description": "seconds to wait before trying again",
                                            "schema": {"type": "integer", "minimum": 1}}}}


GUARD_ERRORS = errors(401, 403, 429)  # what the access guard can answer on any /api operation
