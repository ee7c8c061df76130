"""REST: where a WebXR client places the scene in the room (docs/xr.md "Placement").

Scene units are not metres, and every room differs: a placement is the table height, where the
scene's origin stands on it ([x, z] in the headset's floor frame), which way the scene faces and
the metres per scene unit. A rig keeps a default (set by its lab) and each participant session its
own (made by the headset's placement step); a client uses the session's, else the rig's, else its
built-in default (clients/web/src/xr_placement.js, which checks the same bounds).

Stored as one small JSON file in the data directory, written whole (temp file, then rename).
"""

from __future__ import annotations

import json
import os
import threading
from pathlib import Path
from typing import Annotated

from fastapi import APIRouter, HTTPException, Request
from pydantic import BaseModel, Field

from server.api.errors import errors
from server.api.guard import identity

router = APIRouter(prefix="/api")

FILE = "placement.json"
_lock = threading.Lock()

Metres = Annotated[float, Field(allow_inf_nan=False, ge=-5.0, le=5.0)]


class Placement(BaseModel):
    table_height_m: float = Field(allow_inf_nan=False, ge=0.0, le=2.5, description="table top above the floor, m")
    origin_m: list[Metres] = Field(min_length=2, max_length=2,
                                   description="[x, z] of the scene origin in the headset's floor frame, m")
    yaw_deg: float = Field(0.0, allow_inf_nan=False, ge=-360.0, le=360.0,
                           description="turn about the vertical; 0: the scene's +x points at the floor frame's +z")
    scale_m_per_unit: float = Field(allow_inf_nan=False, ge=0.005, le=2.0, description="metres per scene unit")


def _path(request: Request) -> Path:
    return Path(request.app.state.settings.data_dir) / FILE


def _read(path: Path) -> dict:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return {"rig": None, "sessions": {}}
    return {"rig": data.get("rig"), "sessions": dict(data.get("sessions") or {})}


def _write(path: Path, data: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=1, sort_keys=True))
    os.replace(tmp, path)


def _session_of(request: Request) -> str | None:
    """The caller's session: a participant's own, else, for the lease holder, the participant
    session it opened (staff placing the scene for it). Staff without the lease have none: another
    lab's open session is not theirs to place (policy scope "self")."""
    who = identity(request)
    if who is not None and who.role == "participant":
        return who.session
    lease = getattr(getattr(request.app.state, "access", None), "lease", None)
    if lease is None or who is None or not lease.holds(who):
        return None
    return getattr(lease, "session", None)


@router.get("/placement", responses=errors(),
            summary="The scene's placement in the room for WebXR: the rig's, the session's, and the one to use")
def get_placement(request: Request) -> dict:
    data = _read(_path(request))
    session = _session_of(request)
    mine = data["sessions"].get(session) if session else None
    return {"rig": data["rig"], "session": mine, "session_id": session, "placement": mine or data["rig"]}


@router.put("/placement/rig", responses=errors(400, 422),
            summary="The rig's default placement (a lab's table and scale)")
def put_rig_placement(body: Placement, request: Request) -> dict:
    with _lock:
        data = _read(_path(request))
        data["rig"] = body.model_dump()
        _write(_path(request), data)
    return {"rig": data["rig"]}


@router.put("/placement/session", responses=errors(400, 409, 422),
            summary="This participant session's placement (the headset's placement step)")
def put_session_placement(body: Placement, request: Request) -> dict:
    session = _session_of(request)
    if not session:
        raise HTTPException(409, "no participant session of yours is open: a session's placement is its "
                                 "participant's, or the lease holder's for the session it opened "
                                 "(PUT /api/placement/rig sets the rig's)")
    with _lock:
        data = _read(_path(request))
        data["sessions"][session] = body.model_dump()
        _write(_path(request), data)
    return {"session_id": session, "session": data["sessions"][session]}
