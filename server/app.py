"""Composition root: settings → hub + loop supervisor → FastAPI app. No logic lives here."""

from __future__ import annotations

import asyncio
import gc
from dataclasses import replace
from contextlib import asynccontextmanager

from fastapi import FastAPI, WebSocket
from fastapi.staticfiles import StaticFiles

from devices.manager import DeviceManager
from devices.rig import SimulatedRig, default_rig_dir
from server import __version__
from server.api.experiment_routes import router as experiment_router
from server.api.routes import router
from server.config import Settings
from server.experiment.engine import Experiment
from server.experiment.store import Store, utc_now
from server.hub.hub import Hub
from server.hub.supervisor import LoopSupervisor


async def _flush_recorder(experiment: Experiment, every_s: float = 0.25) -> None:
    """The running trial's rows go to disk in batches, off the event loop."""
    while True:
        await asyncio.sleep(every_s)
        await asyncio.to_thread(experiment.recorder.flush)


def create_app(settings: Settings) -> FastAPI:
    hub = Hub(server_name=f"viestac/{__version__}", tick_hz=settings.tick_hz, state_hz=settings.state_hz)
    supervisor = LoopSupervisor(settings.loop_config(), hub.on_loop_record)
    hub.send_to_loop = supervisor.send
    # A restarted loop comes back with what ran, not with the start-up scenario.
    hub.on_scenario = lambda state: setattr(supervisor, "config", replace(
        supervisor.config, scenario=state["id"], scenario_params=state["params"], seed=state["seed"],
        trial=state["trial"]))

    store = Store(settings.data_dir / "viestac.sqlite", utc_now)
    experiment = Experiment(store, hub, studies_dir=settings.studies_dir, software_version=__version__,
                            config=settings.recorded(), record_every=settings.record_every,
                            force_scenarios=settings.force)

    rig = (SimulatedRig(settings.rig_models, directory=default_rig_dir())
           if settings.simulated_rig and not settings.devices else None)

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        configs = list(settings.devices) + (await asyncio.to_thread(rig.start) if rig else [])
        manager = DeviceManager(configs)
        manager.start()
        hub.attach_devices(manager)
        app.state.devices = manager
        supervisor.start()
        flusher = asyncio.get_running_loop().create_task(_flush_recorder(experiment))
        # The device threads share this process: a full collection over FastAPI's start-up heap
        # paused them for 10-20 ms (measured in tests/devices/test_serial_path.py); freeze it.
        gc.collect()
        gc.freeze()
        yield
        flusher.cancel()
        await asyncio.to_thread(experiment.recorder.flush)
        await supervisor.stop()
        manager.submit(())  # leave every actuator off
        await asyncio.to_thread(manager.stop)
        if rig:
            await asyncio.to_thread(rig.stop)
        store.close()

    app = FastAPI(title="ViESTac", version=__version__, lifespan=lifespan,
                  description="Networked evaluation suite for wearable tactile displays. "
                              "WebSocket protocol: /ws (docs/protocol.md).")
    app.state.settings = settings
    app.state.hub = hub
    app.state.supervisor = supervisor
    app.state.rig = rig
    app.state.experiment = experiment
    app.include_router(router, prefix="/api")
    app.include_router(experiment_router, prefix="/api")

    @app.websocket("/ws")
    async def websocket(ws: WebSocket) -> None:
        await hub.serve(ws)

    if settings.web_root.is_dir():
        app.mount("/", StaticFiles(directory=settings.web_root, html=True), name="web")
    return app
