"""REST routes: thin views over the hub and the loop supervisor (OpenAPI at /docs).

Every handler is `async def`: it runs on the event loop's thread, which owns the hub, the
supervisor and the device host (server/hub/owner.py); a plain `def` would run on a worker thread.
Nothing here blocks: each handler reads the hub or sends one record to the loop.

Who may call what is the access guard's (server/api/guard.py). While a study session's trial is
recorded, the rig belongs to that session: a scenario switch or a trial start/stop from here is
refused (409) — it would end or change the recorded trial behind the experimenter's back — and
goes through the session's own routes instead (abort the trial first)."""

from __future__ import annotations

import time
from typing import Annotated

from typing import Any, Literal

from fastapi import APIRouter, Depends, HTTPException, Query, Request
from pydantic import BaseModel, Field

from server.api.errors import MAX_INT, errors
from server.api.guard import identity

from server.core.scenario import ParamError, describe
from scenarios.registry import SCENARIOS, UnknownScenario
from server import __version__
from server.hub.device_host import DeviceHostUnavailable
from server.hub.control import BusyError, DeviceMissing, ScenarioRefused
from server.hub.hub import Hub
from server.hub.supervisor import LoopSupervisor

router = APIRouter(prefix="/api")
_STARTED = time.monotonic()


async def get_hub(request: Request) -> Hub:
    return request.app.state.hub


async def get_supervisor(request: Request) -> LoopSupervisor:
    return request.app.state.supervisor


async def rig_free(request: Request) -> None:
    """409 while a session's trial is recorded (the session's routes own the rig meanwhile)."""
    experiment = getattr(request.app.state, "experiment", None)
    session = experiment.recording() if experiment is not None else None
    if session is not None:
        raise HTTPException(409, f"a trial of session {session} is being recorded; abort it through the session "
                                 f"(POST /api/sessions/{session}/trials/{{seq}}/abort) before changing the rig")


HubDep = Annotated[Hub, Depends(get_hub)]
SupervisorDep = Annotated[LoopSupervisor, Depends(get_supervisor)]
RigFree = Depends(rig_free)


def _cpu_plan(request: Request) -> dict | None:
    plan = getattr(request.app.state, "cpu_plan", None)
    return plan.to_dict() if plan is not None else None


@router.get("/health", summary="Server and 1 kHz loop status (ok | degraded | starting, with the reasons a "
                                "person can act on), with loop timing over the last 10 s")
async def health(request: Request, hub: HubDep, supervisor: SupervisorDep) -> dict:
    alive = supervisor.alive
    report = hub.health_feed.check_health()  # server/hub/health.py; the same verdict the clients' `health` message carries
    return {"status": report.status, "reasons": list(report.reasons), "notes": list(report.notes),
            "version": __version__, "uptime_s": round(time.monotonic() - _STARTED, 3),
            "loop": {"alive": alive, "pid": hub.link.loop_info.get("pid"), "rt": hub.link.telemetry.rt,
                     "cpu": hub.link.loop_info.get("cpu"), "cpus": _cpu_plan(request),
                     "restarts": supervisor.restarts, "scenario": hub.link.loop_info.get("scenario"),
                     "tick_hz": hub.fanout.server.tick_hz, "state_hz": hub.fanout.server.state_hz,
                     "dropped_to_loop": supervisor.dropped_to_loop},
            "telemetry": hub.link.telemetry_summary(), "clients": len(hub.fanout.connections), "scene": hub.fanout.scene_hash,
            "tracker_udp": getattr(request.app.state, "tracker_udp", None),
            "warnings": [r["text"] for r in hub.link.log_records if r["level"] == "warning"][-5:]}


@router.get("/scenarios", summary="Scenarios this server can run, with their parameters, controls, study "
                                  "parts and required tactile dimensions, and whether the configured devices can run them")
async def scenarios(hub: HubDep) -> list[dict]:
    return [{**describe(spec.factory), "capability": hub.control.capability(spec.factory).to_dict()}
            for spec in SCENARIOS.values()]


class ScenarioRequest(BaseModel):
    name: str = Field(description="scenario id or bare name, e.g. 'texture' or 'texture-v1'")
    params: dict[str, Any] = Field(default_factory=dict, description="the scenario's PARAMS (GET /api/scenarios)")
    seed: int = Field(0, ge=0, le=MAX_INT, description="seed of the scenario's random choices (e.g. the stiffness 'n' key)")
    force: bool = Field(False, description="switch even when no configured device can show the scenario")


class TrialRequest(BaseModel):
    phase: Literal["training", "trial", "main"]
    params: dict[str, Any] = Field(default_factory=dict, description="the scenario's TRIAL_PARAMS")
    index: int = Field(0, ge=0, le=MAX_INT, description="trial number within its phase (shown to the participant)")
    force: bool = Field(False, description="start even when a device the scenario needs is not connected")


class CommandRequest(BaseModel):
    key: str = Field(min_length=1, max_length=32, description="a key or command of the scenario's CONTROLS")
    action: Literal["down", "up", "press"] = "press"
    value: bool | float | str | None = None


def _busy_or_bad(exc: Exception) -> HTTPException:
    if isinstance(exc, BusyError):
        return HTTPException(503, str(exc))
    return HTTPException(422, str(exc))


@router.get("/scenario", responses=errors(503), summary="The running scenario: id, parameters, trial, declaration, capability check")
async def scenario(hub: HubDep) -> dict:
    info = hub.control.info(hub.fanout.scene_hash)  # the scene the scenario announced (it comes first)
    if not info:
        raise HTTPException(503, "the loop has not announced its scenario yet")
    return info


@router.post("/scenario", dependencies=[RigFree], responses=errors(400, 404, 409, 422, 503), summary="Switch the running scenario (the new scene goes to every client); 409 when no "
                                  "configured device can show it, unless force")
async def switch_scenario(body: ScenarioRequest, hub: HubDep) -> dict:
    try:
        return hub.control.switch_scenario(body.name, body.params, body.seed, body.force)
    except UnknownScenario as exc:
        raise HTTPException(404, str(exc)) from None
    except ScenarioRefused as exc:
        raise HTTPException(409, exc.report.message) from None
    except (ParamError, BusyError) as exc:
        raise _busy_or_bad(exc) from None


@router.post("/trial", dependencies=[RigFree], responses=errors(400, 409, 422, 503), summary="Start a trial of the running scenario (phase and "
                                                                     "trial parameters); 409 when a device it needs is "
                                                                     "not connected, unless force")
async def start_trial(body: TrialRequest, hub: HubDep) -> dict:
    try:
        return {"trial": hub.control.set_trial(body.phase, body.params, body.index, body.force)}
    except DeviceMissing as exc:
        raise HTTPException(409, exc.report.message) from None
    except (ParamError, BusyError) as exc:
        raise _busy_or_bad(exc) from None


@router.delete("/trial", dependencies=[RigFree], responses=errors(409, 503), summary="End the running trial (back to "
                                                                                     "free exploration)")
async def end_trial(hub: HubDep) -> dict:
    try:
        return {"trial": hub.control.set_trial(None)}
    except BusyError as exc:
        raise _busy_or_bad(exc) from None


@router.post("/command", responses=errors(400, 409, 422, 503), summary="Send a key or experimenter command to the running "
             "scenario, as an operator; 409 while another lab's trial is recorded")
async def command(body: CommandRequest, hub: HubDep, request: Request) -> dict:
    # REST commands are client 0's: its events name the caller (only the lease holder may send them)
    hub.fanout.event_log.name_actor(0, identity(request))
    try:
        hub.control.command(body.key, body.action, body.value, role="operator")
    except (ParamError, BusyError) as exc:
        raise _busy_or_bad(exc) from None
    return {"ok": True}


@router.get("/scene", responses=errors(503), summary="The current static scene (docs/protocol.md scene format)")
async def scene(hub: HubDep) -> dict:
    if hub.fanout.scene is None:
        raise HTTPException(503, "the loop has not published a scene yet")
    return {"hash": hub.fanout.scene_hash, "scene": hub.fanout.scene}


@router.get("/state", responses=errors(503), summary="The latest state frame")
async def state(hub: HubDep) -> dict:
    if hub.link.last_state is None:
        raise HTTPException(503, "no state yet")
    return hub.link.last_state


@router.get("/clients", summary="Connected WebSocket clients with their counters")
async def clients(hub: HubDep) -> list[dict]:
    return hub.fanout.clients()


@router.get("/devices", responses=errors(422, 503), summary="Configured tactile devices: status, identity, link counters, refusals")
async def devices(request: Request, writes: int = Query(0, ge=0, le=1024, description=
                  "also list each device's latest N writes as [CLOCK_MONOTONIC ns when write() returned, hex bytes]")) -> dict:
    host = getattr(request.app.state, "device_host", None)
    rig = request.app.state.rig
    try:
        snapshot = await host.snapshot(writes) if host is not None else {"devices": [], "refusals": [], "feed": None}
    except DeviceHostUnavailable as exc:
        raise HTTPException(503, str(exc)) from None
    browser = request.app.state.hub.actuators.snapshot()  # the participant's page, driven by the hub itself
    if browser is not None:
        snapshot = {**snapshot, "devices": [*snapshot["devices"], browser]}
    return {**snapshot, "host": {"pid": host.info.get("pid"), "alive": host.alive, "restarts": host.restarts}
            if host is not None else None, "simulated_rig": rig.info() if rig is not None else None}


@router.get("/telemetry", summary="Loop timing since the last reset (exact to 1 µs)")
async def telemetry(hub: HubDep) -> dict:
    return hub.link.telemetry.cumulative()


@router.get("/trackers", responses=errors(422), summary="Recent tracker samples with when the hub received and the loop applied them")
async def trackers(hub: HubDep, request: Request, limit: int = 1000) -> dict:
    rows = list(hub.link.tracker_applied)[-max(1, min(limit, 4096)):]
    host = getattr(request.app.state, "tracker_host", None)  # the --tracker sources' health (docs/trackers.md)
    return {"columns": ["client_id", "seq", "t_ms", "hub_recv_ns", "loop_applied_ns"], "rows": rows,
            "clock": "hub_recv_ns and loop_applied_ns are CLOCK_MONOTONIC of the server machine",
            "sources": list(host.sources) if host is not None else []}


@router.post("/telemetry/reset", summary="Start a new cumulative timing window")
async def telemetry_reset(hub: HubDep) -> dict:
    hub.link.telemetry.reset_cumulative()
    return {"ok": True}
