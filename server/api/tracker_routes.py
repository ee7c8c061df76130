"""REST: tracker sources' calibration (docs/trackers.md "Calibration"). Their health is in
`GET /api/trackers` (`sources`, server/api/routes.py).

The routines: capture the raw position of the tracked points (the mean over a short hold), then
either fit a calibration from ≥ 3 captured points and the scene points they touched, or move the
offset so one held point lands on its reference. The fit is pure (server/tracking/calibration.py)
and runs here; the tracker host stores the result in the data dir and applies it at once.
"""

from __future__ import annotations

from typing import Annotated, Literal

from fastapi import APIRouter, HTTPException, Request
from pydantic import BaseModel, Field

from server.api.errors import errors
from server.hub.tracker_host import TrackerHost, TrackerHostUnavailable
from server.tracking import calibration as cal

router = APIRouter(prefix="/api")

Vec = Annotated[list[Annotated[float, Field(allow_inf_nan=False)]], Field(min_length=3, max_length=3)]


class Capture(BaseModel):
    seconds: float = Field(0.5, gt=0, le=3.0, description="average the raw samples of the last this many seconds")


class Pair(BaseModel):
    source: Vec = Field(description="the point as the source reported it (its frame and units; a capture's mean)")
    scene: Vec = Field(description="the marked scene point it touched (scene units)")


class CalibrationBody(BaseModel):
    method: Literal["points", "hold"] = Field(description="points: fit from ≥ 3 pairs; hold: move the offset "
                                                          "so one held point lands on its reference")
    pairs: list[Pair] = Field(min_length=1, max_length=64)
    scale: bool = Field(True, description="points: fit the scale too (false keeps scale 1 × the unit)")


def _host(request: Request) -> TrackerHost:
    host = getattr(request.app.state, "tracker_host", None)
    if host is None:
        raise HTTPException(404, "no tracker sources run on this server (viestac serve --tracker ...)")
    return host


def _source(host: TrackerHost, name: str) -> dict:
    for entry in host.sources:
        if entry.get("name") == name:
            return entry
    raise HTTPException(404, f"no tracker source {name!r}; the sources are "
                             f"{', '.join(s.get('name', '?') for s in host.sources) or 'none'}")


async def _answer(coro) -> dict:
    try:
        answer = await coro
    except TrackerHostUnavailable as exc:
        raise HTTPException(503, str(exc)) from None
    if not answer.get("ok"):
        raise HTTPException(422, answer.get("error", "refused"))
    return answer


@router.post("/trackers/{source}/capture", responses=errors(400, 404, 422, 503),
             summary="The mean raw position of each tracked point over the last seconds (for a calibration)")
async def capture(source: str, body: Capture, request: Request) -> dict:
    host = _host(request)
    _source(host, source)
    return await _answer(host.capture(source, body.seconds))


@router.put("/trackers/{source}/calibration", responses=errors(400, 404, 422, 503),
            summary="Calibrate a tracker source from captured points and the scene points they touched")
async def calibrate(source: str, body: CalibrationBody, request: Request) -> dict:
    host = _host(request)
    entry = _source(host, source)
    try:
        current = cal.Calibration.from_dict(entry["calibration"]) if entry.get("calibration") else cal.Calibration()
        if body.method == "points":
            if len(body.pairs) < 3:
                raise ValueError("a points calibration needs at least 3 pairs")
            new = cal.fit([p.source for p in body.pairs], [p.scene for p in body.pairs], units=current.units,
                          with_scale=body.scale)
            if not body.scale:  # keep the unit conversion: fit in the scaled source frame
                scaled = [[v * current.scale for v in p.source] for p in body.pairs]
                new = cal.fit(scaled, [p.scene for p in body.pairs], units=current.units, with_scale=False)
                new = cal.Calibration(rotation=new.rotation, scale=current.scale, offset=new.offset,
                                      units=current.units, residual=new.residual, method="points")
        else:
            if len(body.pairs) != 1:
                raise ValueError("a hold calibration takes exactly one pair")
            new = cal.hold_still(current, body.pairs[0].source, body.pairs[0].scene)
    except ValueError as exc:
        raise HTTPException(422, str(exc)) from None
    answer = await _answer(host.calibrate(source, new.to_dict()))
    return {"source": source, "calibration": answer["calibration"]}


@router.delete("/trackers/{source}/calibration", responses=errors(400, 404, 422, 503),
               summary="Back to the source kind's default calibration")
async def reset_calibration(source: str, request: Request) -> dict:
    host = _host(request)
    _source(host, source)
    answer = await _answer(host.calibrate(source, None))
    return {"source": source, "calibration": answer["calibration"]}
