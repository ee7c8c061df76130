"""REST routes: thin views over the hub and the loop supervisor (OpenAPI at /docs)."""

from __future__ import annotations

import time
from typing import Annotated

from fastapi import APIRouter, Depends, HTTPException, Request

from scenarios.registry import SCENARIOS
from server import __version__
from server.hub.hub import Hub
from server.hub.supervisor import LoopSupervisor

router = APIRouter()
_STARTED = time.monotonic()


def get_hub(request: Request) -> Hub:
    return request.app.state.hub


def get_supervisor(request: Request) -> LoopSupervisor:
    return request.app.state.supervisor


HubDep = Annotated[Hub, Depends(get_hub)]
SupervisorDep = Annotated[LoopSupervisor, Depends(get_supervisor)]


@router.get("/health", summary="Server and 1 kHz loop status, with loop timing over the last 10 s")
def health(hub: HubDep, supervisor: SupervisorDep) -> dict:
    alive = supervisor.alive
    return {"status": "ok" if alive and hub.states_received else "starting" if alive else "degraded",
            "version": __version__, "uptime_s": round(time.monotonic() - _STARTED, 3),
            "loop": {"alive": alive, "pid": hub.loop_info.get("pid"), "rt": hub.telemetry.rt,
                     "restarts": supervisor.restarts, "scenario": hub.loop_info.get("scenario"),
                     "tick_hz": hub.tick_hz, "state_hz": hub.state_hz,
                     "dropped_to_loop": supervisor.dropped_to_loop},
            "telemetry": hub.telemetry_summary(), "clients": len(hub.sessions), "scene": hub.scene_hash,
            "warnings": [r["text"] for r in hub.log_records if r["level"] == "warning"][-5:]}


@router.get("/scenarios", summary="Scenarios this server can run")
def scenarios() -> list[dict]:
    return [{"id": spec.id, "title": spec.title} for spec in SCENARIOS.values()]


@router.get("/scene", summary="The current static scene (docs/protocol.md scene format)")
def scene(hub: HubDep) -> dict:
    if hub.scene is None:
        raise HTTPException(503, "the loop has not published a scene yet")
    return {"hash": hub.scene_hash, "scene": hub.scene}


@router.get("/state", summary="The latest state frame")
def state(hub: HubDep) -> dict:
    if hub.last_state is None:
        raise HTTPException(503, "no state yet")
    return hub.last_state


@router.get("/clients", summary="Connected WebSocket clients with their counters")
def clients(hub: HubDep) -> list[dict]:
    return hub.clients()


@router.get("/devices", summary="Configured tactile devices: status, identity, link counters, refusals")
def devices(request: Request) -> dict:
    manager = getattr(request.app.state, "devices", None)
    rig = request.app.state.rig
    snapshot = manager.snapshot() if manager is not None else {"devices": [], "refusals": []}
    return {**snapshot, "simulated_rig": rig.info() if rig is not None else None}


@router.get("/telemetry", summary="Loop timing since the last reset (exact to 1 µs)")
def telemetry(hub: HubDep) -> dict:
    return hub.telemetry.cumulative()


@router.get("/trackers", summary="Recent tracker samples with when the hub received and the loop applied them")
def trackers(hub: HubDep, limit: int = 1000) -> dict:
    rows = list(hub.tracker_applied)[-max(1, min(limit, 4096)):]
    return {"columns": ["client_id", "seq", "t_ms", "hub_recv_ns", "loop_applied_ns"], "rows": rows,
            "clock": "hub_recv_ns and loop_applied_ns are CLOCK_MONOTONIC of the server machine"}


@router.post("/telemetry/reset", summary="Start a new cumulative timing window")
def telemetry_reset(hub: HubDep) -> dict:
    hub.telemetry.reset_cumulative()
    return {"ok": True}
