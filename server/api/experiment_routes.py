"""REST routes of the experiment engine: studies, sessions and the trial lifecycle (everything the
experimenter's console does). Thin: validate, call the engine, map its errors to status codes.

Who may call what is the access guard's (server/api/guard.py): a lab's experimenter sees and
changes only its own site's sessions (another site's answer 404, as if they did not exist), the
admin every site's. Within that, changes to a session need the control token its creation (or `POST .../control`) returned, in
the `X-Control-Token` header; each names the trial it is about, so a stale console gets 409.

The handlers are plain `def`: FastAPI runs them on worker threads, so the engine's SQLite work
never blocks the event loop. The engine reaches the hub only through the app's `HubForWorkers`,
which runs each hub call on the event loop's thread (server/hub/owner.py).
"""

from __future__ import annotations

import asyncio
from typing import Annotated, Any

from fastapi import APIRouter, Depends, Header, HTTPException, Path, Query, Request
from pydantic import BaseModel, Field

from server.api.errors import MAX_INT, errors
from server.api.guard import site_scope

from server.core.scenario import ParamError
from scenarios.registry import UnknownScenario
from server.experiment.engine import Experiment, ExperimentError, Forbidden, NotFound
from server.experiment.plan import plan_session
from server.experiment.store import Conflict, StoreError
from server.hub.control import BusyError, ScenarioRefused

router = APIRouter(prefix="/api", tags=["experiment"])


def get_experiment(request: Request) -> Experiment:
    return request.app.state.experiment


ExperimentDep = Annotated[Experiment, Depends(get_experiment)]
SiteDep = Annotated[str | None, Depends(site_scope)]  # whose sessions the caller sees (None: every site's)
TokenDep = Annotated[str | None, Header(alias="X-Control-Token", description="the session's control token")]
SeqPath = Annotated[int, Path(ge=0, le=MAX_INT, description="the trial's position in the session (0..)")]
ParticipantIndex = Annotated[int, Query(ge=0, le=MAX_INT, description="row of the counterbalancing (0..)")]


def _http(exc: Exception) -> HTTPException:
    """One mapping of the engine's, store's and hub's errors to status codes."""
    if isinstance(exc, NotFound | UnknownScenario):
        return HTTPException(404, str(exc))
    if isinstance(exc, Forbidden):
        return HTTPException(403, str(exc))
    if isinstance(exc, Conflict | ScenarioRefused):
        return HTTPException(409, getattr(getattr(exc, "report", None), "message", None) or str(exc))
    if isinstance(exc, BusyError):
        return HTTPException(503, str(exc))
    if isinstance(exc, StoreError):  # a transition the lifecycle does not allow
        return HTTPException(409, str(exc))
    return HTTPException(422, str(exc))


ERRORS = (ExperimentError, StoreError, ParamError, UnknownScenario, ScenarioRefused, BusyError)


class SessionCreate(BaseModel):
    study: str = Field(description="a study id (GET /api/studies)")
    participant: str = Field(description="pseudonymous participant code: 1-32 letters, digits, '-' or '_' with at "
                                         "least one digit, such as P07 (never a name)")
    experimenter: str
    device: str | None = Field(None, description="the device worn (model or name), recorded with the session")
    notes: str = ""
    participant_index: int | None = Field(None, ge=0, le=MAX_INT, description="row of the counterbalancing (default: the "
                                                                  "next one for this study)")
    site: str | None = Field(None, min_length=1, max_length=64, description="the lab the session belongs to (admin "
                                                                            "only; an experimenter's is its own)")


class ControlRequest(BaseModel):
    experimenter: str = Field(min_length=1, max_length=64)


class AnswerRequest(BaseModel):
    value: Any = Field(description="the answer; checked against the question (Likert 1-7, number, choice, text)")
    entered_by: str = Field("experimenter", max_length=64)


class ReasonRequest(BaseModel):
    reason: str = Field("", max_length=500)


class NotesRequest(BaseModel):
    notes: str = Field(max_length=10_000)


@router.get("/studies", summary="Study files in the studies directory (a broken one with its error)")
def studies(experiment: ExperimentDep) -> list[dict]:
    return experiment.studies()


@router.get("/studies/{study_id}", responses=errors(404, 422), summary="One study: tasks, conditions, orders, questions")
def study(study_id: str, experiment: ExperimentDep) -> dict:
    try:
        return experiment.study(study_id).to_dict()
    except ERRORS as exc:
        raise _http(exc) from None


@router.get("/studies/{study_id}/plan", responses=errors(404, 422), summary="The planned trials of one participant (counterbalancing row)")
def study_plan(study_id: str, experiment: ExperimentDep, participant_index: ParticipantIndex = 0) -> list[dict]:
    try:
        return [p.to_dict() for p in plan_session(experiment.study(study_id), participant_index)]
    except ERRORS as exc:
        raise _http(exc) from None


@router.get("/sessions", summary="The sessions of your site (admin: all) with their progress")
def sessions(experiment: ExperimentDep, site: SiteDep) -> list[dict]:
    return experiment.sessions(site)


@router.post("/sessions", status_code=201, responses=errors(400, 403, 404, 409, 422), summary="A new session: the study's plan for one participant; returns the "
                                                    "control token")
def create_session(body: SessionCreate, experiment: ExperimentDep, site: SiteDep, request: Request) -> dict:
    if site is None:  # the admin's: the site asked for (None: a session of no lab, only the admin sees it)
        site = body.site
    elif body.site is not None and body.site != site:
        raise HTTPException(403, f"your sessions belong to site {site!r}; only the admin makes another site's")
    try:
        created = experiment.create_session(study_id=body.study, participant=body.participant,
                                            experimenter=body.experimenter, device=body.device, notes=body.notes,
                                            participant_index=body.participant_index, site=site or None)
    except ERRORS as exc:
        raise _http(exc) from None
    request.state.audit_session_id = created["id"]  # the audit row names the session it made
    return created


@router.get("/sessions/{session_id}", responses=errors(404, 422), summary="A session with its queue of trials, statuses and answers")
def session(session_id: str, experiment: ExperimentDep, site: SiteDep, request: Request) -> dict:
    try:
        shown = experiment.session(session_id, site)
    except ERRORS as exc:
        raise _http(exc) from None
    # a participant-paced task's state: {state, done, total, feedback, note} (docs/studies.md), else null
    paced = request.app.state.paced
    pacing = paced.console_view(session_id)
    if pacing is None and _paced(experiment, shown):  # not seen since the server started: the next read shows it
        paced.look(session_id)
    return {**shown, "pacing": pacing}


def _paced(experiment: Experiment, session: dict) -> bool:
    try:
        return any(t.pacing.paced for t in experiment.study(session["study_id"]).tasks)
    except NotFound:  # the study file is gone: nothing is paced
        return False


@router.get("/sessions/{session_id}/tracks", responses=errors(404, 422),
            summary="The psychophysics tasks of a session with their tracks: levels, answers, reversals, estimates")
def tracks(session_id: str, experiment: ExperimentDep, site: SiteDep) -> dict:
    try:
        return experiment.tracks(session_id, site)
    except ERRORS as exc:
        raise _http(exc) from None


@router.post("/sessions/{session_id}/control", responses=errors(400, 404, 409, 422), summary="Take control of a session from this console (the previous "
                                                        "token stops working)")
def take_control(session_id: str, body: ControlRequest, experiment: ExperimentDep, site: SiteDep) -> dict:
    try:
        return {"token": experiment.take_control(session_id, body.experimenter, site)}
    except ERRORS as exc:
        raise _http(exc) from None


@router.get("/sessions/{session_id}/control", responses=errors(404, 422), summary="Who controls the session, and whether this console's token "
                                                       "(X-Control-Token) is the current one")
def control(session_id: str, experiment: ExperimentDep, site: SiteDep, token: TokenDep = None) -> dict:
    try:
        return experiment.control(session_id, token, site)
    except ERRORS as exc:
        raise _http(exc) from None


@router.put("/sessions/{session_id}/notes", responses=errors(400, 403, 404, 409, 422), summary="Replace the session's notes")
def notes(session_id: str, body: NotesRequest, experiment: ExperimentDep, site: SiteDep, token: TokenDep = None) -> dict:
    try:
        experiment.set_notes(session_id, token, body.notes, site=site)
    except ERRORS as exc:
        raise _http(exc) from None
    return {"ok": True}


@router.post("/sessions/{session_id}/trials/{seq}/start", responses=errors(403, 404, 409, 422, 503), summary="Start the next pending trial (its scenario and "
                                                                  "trial go to the loop, recording starts)")
def start(session_id: str, seq: SeqPath, experiment: ExperimentDep, site: SiteDep, request: Request,
          token: TokenDep = None, force: bool = Query(False, description="start even when a device the scenario "
                                                                         "needs is not connected (otherwise 409)")) -> dict:
    try:
        started = experiment.start(session_id, token, seq, force, site=site)
    except ERRORS as exc:
        raise _http(exc) from None
    # the starter holds the lease: its participant session is the open one from now on (its
    # participant may drive in its own trial, whatever join link was made last)
    request.app.state.access.follow_running()
    return started


@router.put("/sessions/{session_id}/trials/{seq}/responses/{question}", responses=errors(400, 403, 404, 409, 422), summary="Enter or correct one answer")
def answer(session_id: str, seq: SeqPath, question: str, body: AnswerRequest, experiment: ExperimentDep,
           site: SiteDep, token: TokenDep = None) -> dict:
    try:
        return experiment.answer(session_id, token, seq, question, body.value, body.entered_by, site=site)
    except ERRORS as exc:
        raise _http(exc) from None


@router.post("/sessions/{session_id}/trials/{seq}/finish", responses=errors(403, 404, 409, 422, 503), summary="The running trial is answered (needs every "
                                                                   "required answer); committed with its data")
def finish(session_id: str, seq: SeqPath, experiment: ExperimentDep, site: SiteDep, token: TokenDep = None) -> dict:
    try:
        return experiment.finish(session_id, token, seq, site=site)
    except ERRORS as exc:
        raise _http(exc) from None


@router.post("/sessions/{session_id}/trials/{seq}/abort", responses=errors(400, 403, 404, 409, 422, 503), summary="Abort the running trial")
def abort(session_id: str, seq: SeqPath, body: ReasonRequest, experiment: ExperimentDep, site: SiteDep,
          token: TokenDep = None) -> dict:
    try:
        return experiment.abort(session_id, token, seq, body.reason, site=site)
    except ERRORS as exc:
        raise _http(exc) from None


@router.post("/sessions/{session_id}/trials/{seq}/retry", responses=errors(403, 404, 409, 422), summary="An aborted trial back into the queue")
def retry(session_id: str, seq: SeqPath, experiment: ExperimentDep, site: SiteDep, token: TokenDep = None) -> dict:
    try:
        return experiment.retry(session_id, token, seq, site=site)
    except ERRORS as exc:
        raise _http(exc) from None


@router.post("/sessions/{session_id}/trials/{seq}/exclude", responses=errors(400, 403, 404, 409, 422), summary="Exclude an answered or aborted trial from "
                                                                    "analysis, with a reason")
def exclude(session_id: str, seq: SeqPath, body: ReasonRequest, experiment: ExperimentDep, site: SiteDep,
             token: TokenDep = None) -> dict:
    try:
        return experiment.exclude(session_id, token, seq, body.reason, site=site)
    except ERRORS as exc:
        raise _http(exc) from None


async def _pacing(session_id: str, experiment: Experiment, site: str | None, token: str | None) -> None:
    """The caller may drive the session's pacing: it holds the control token (403), its site sees it (404)."""
    try:
        control = await asyncio.to_thread(experiment.control, session_id, token, site)
    except ERRORS as exc:
        raise _http(exc) from None
    if not control["yours"]:
        raise _http(Forbidden("this console does not control the session; take control first"))


@router.post("/sessions/{session_id}/pacing/pause", responses=errors(403, 404, 422), summary="Pause a participant-paced "
             "task: no trial starts until resumed (a running one may still be answered)")
async def pause_pacing(session_id: str, experiment: ExperimentDep, site: SiteDep, request: Request,
                       token: TokenDep = None) -> dict:
    await _pacing(session_id, experiment, site, token)
    request.app.state.paced.pause(session_id)
    return {"ok": True}


@router.post("/sessions/{session_id}/pacing/resume", responses=errors(403, 404, 422), summary="Resume a participant-paced "
             "task: its next trial starts after the inter-trial interval (also after a pause by itself, a restart "
             "or an abort)")
async def resume_pacing(session_id: str, experiment: ExperimentDep, site: SiteDep, request: Request,
                        token: TokenDep = None) -> dict:
    await _pacing(session_id, experiment, site, token)
    request.app.state.paced.resume(session_id)
    return {"ok": True}
