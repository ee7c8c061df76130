"""Composition root: settings → hub + loop supervisor → FastAPI app. No logic lives here."""

from __future__ import annotations

import asyncio
import gc
import logging
import os
from contextlib import asynccontextmanager

from fastapi import Depends, FastAPI, WebSocket

from devices.rig import SimulatedRig, default_rig_dir
from server import __version__
from server.api.access_routes import router as access_router
from server.api.errors import GUARD_ERRORS
from server.api.browser_safety import BrowserSafety, options_for
from server.api.experiment_routes import router as experiment_router
from server.api.paced_sessions import PacedSessions
from server.api.participant_answers import ParticipantAnswers
from server.api.placement_routes import router as placement_router
from server.api.guard import AuditTrail, guard, install_access_doc
from server.api.routes import router
from server.api.tracker_routes import router as tracker_router
from server.auth import AccessControl, RunningTrial
from server.api.web_client import WebClient, install_docs
from server.config import Settings
from server.cpu_plan import CpuPlan, plan_cpus
from server.experiment.engine import Experiment, NotFound
from server.experiment.store import Store, utc_now
from server.hub.device_host import DeviceHost
from server.hub.hub import Hub
from server.hub.owner import HubForWorkers, Owner
from server.hub.supervisor import LoopSupervisor
from server.hub.tracker_host import TrackerHost
from server.loop import tracker_udp

log = logging.getLogger("viestac")


ADMIN_TOKEN_ENV = "VIESTAC_ADMIN_TOKEN"  # a token the tests and benches register for this run (never stored)


async def _tick_lease(access: AccessControl, hub: Hub, every_s: float = 0.25) -> None:
    """A quiet holder or queued requester loses its place (the lease's expiry), a token revoked by
    the CLI (the store's data_version moved) or past its expiry ends its /ws connections: on the
    event loop, every `every_s`."""
    while True:
        await asyncio.sleep(every_s)
        try:
            access.tick()
            hub.check_tokens(None, access.clock())
        except Exception:  # a failed tick (a busy disk) must not end the task; the next one tries again
            log.exception("lease tick failed")


def _running_trial(experiment: Experiment):
    """access.running: the trial recorded now with its session's lab (looked up once per session)."""
    sites: dict[str, str | None] = {}

    def running() -> RunningTrial | None:
        session = experiment.recording()
        if session is None:
            return None
        if session not in sites:
            try:
                site = experiment.site_of(session)
            except NotFound:
                return None
            sites.clear()
            sites[session] = site
        return RunningTrial(session, sites[session])

    return running


def _access_control(settings: Settings) -> AccessControl:
    access = AccessControl.open(settings.data_dir, lease_ttl_s=settings.lease_ttl_s)
    secret = os.environ.get(ADMIN_TOKEN_ENV)
    if secret:
        access.book.add_ephemeral(secret, "admin", label="env")
    return access


def _resumable(state: dict | None, experiment: Experiment) -> dict | None:
    """What a restarted loop runs: what the loop last announced, with its trial unless a trial is
    recorded (the experiment ends that attempt as interrupted, docs/data.md)."""
    if state is None or experiment.recorder.active is None:
        return state
    return {**state, "trial": None}


async def _flush_recorder(experiment: Experiment, every_s: float = 0.25) -> None:
    """The running trial's rows go to disk in batches, off the event loop."""
    while True:
        await asyncio.sleep(every_s)
        await asyncio.to_thread(experiment.flush)


def create_app(settings: Settings, tracker_sock=None, cpu_plan: CpuPlan | None = None) -> FastAPI:
    """`tracker_sock`: the tracker UDP port bound already (viestac serve binds it first, to fail
    early and print it); otherwise it is bound at start-up from settings.tracker_address().
    `cpu_plan`: where the loop and the other processes run (viestac serve plans it and keeps this
    process off the loop's CPU first); otherwise planned here from this process's CPUs."""
    if cpu_plan is None:
        cpu_plan = plan_cpus(os.sched_getaffinity(0), settings.loop_cpu)
    owner = Owner("the hub")  # one thread owns the hub and its children: the event loop's (server/hub/owner.py)
    access = _access_control(settings)  # the clients see the lease as it changes (protocol v1.3 `lease`)
    # The loop's records go to the hub's loop link; a restarted loop comes back with what ran
    # (the hub's scenario control owns it), not with the start-up scenario.
    supervisor = LoopSupervisor(settings.loop_config(cpu=cpu_plan.loop), lambda record: hub.link.on_loop_record(record),
                                resume=lambda: _resumable(hub.control.state, experiment))
    supervisor.owner = owner
    hub = Hub(server_name=f"viestac/{__version__}", tick_hz=settings.tick_hz, state_hz=settings.state_hz,
              overrun_threshold=settings.overrun_threshold, send_to_loop=supervisor.send, access=access, owner=owner)

    store = Store(settings.data_dir / "viestac.sqlite", utc_now)
    # REST runs the engine on worker threads (SQLite off the event loop); its hub calls run on the owner.
    experiment = Experiment(store, HubForWorkers(hub, owner), studies_dir=settings.studies_dir, software_version=__version__,
                            config=settings.recorded(), record_every=settings.record_every,
                            force_scenarios=settings.force)

    # participants answer the study's questions over /ws (protocol v1.5 `ask`, `answer`)
    answers = ParticipantAnswers(experiment, hub.answers, access.audit)
    hub.answers.connect(answers.answer, answers.view)
    # participant-paced tasks move on by themselves while a console holds the session (docs/studies.md)
    paced = answers.pacing = PacedSessions(experiment, owner, answers.changed)

    def changed(session_id: str) -> None:
        if not paced.paces(session_id):  # a paced session's `ask` follows the pacer's step (with its state)
            answers.changed(session_id)
        paced.changed(session_id)

    experiment.on_change = changed
    access.running = _running_trial(experiment)  # the rig is the running trial's lab's (docs/security.md)

    def tokens_changed() -> None:  # a revocation here or by the CLI: the connections of that token end now
        if owner.here:
            hub.check_tokens(access.standing, access.clock())
        else:
            owner.loop.call_soon_threadsafe(hub.check_tokens, access.standing, access.clock())

    access.on_tokens_changed = tokens_changed

    rig = (SimulatedRig(settings.rig_models, directory=default_rig_dir())
           if settings.simulated_rig and not settings.devices else None)

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        owner.bind()
        feed = hub.health_feed
        # each device on its finger (rig file `finger`, --finger): it gets that tool's cues only
        configs = settings.device_configs(await asyncio.to_thread(rig.start) if rig else [])
        feed.device_profiles = {c.name: c.profile for c in configs}  # until the devices identify themselves
        # the participant's page is the browser device: the hub drives it over /ws, the host never sees it
        hub.actuators.configure(next((c for c in configs if c.profile.protocol == "browser"), None))
        devices = DeviceHost([c for c in configs if c.profile.protocol != "browser"],
                             on_report=hub.link.on_device_report,
                             on_profiles=lambda profiles: setattr(feed, "device_profiles",
                                                                  {**profiles, **hub.actuators.profiles()}))
        devices.owner = owner
        # health hears of every start and exit at once, not at its next 25 ms poll
        for name, child in (("loop", supervisor), ("device_host", devices)):
            child.on_start = lambda _what, name=name: feed.on_child_start(name)
            child.on_exit = lambda _what, code, name=name: feed.on_child_exit(name, code)
        devices.start()  # the serial devices and the cue feed run in a process of their own
        supervisor.cue_sock = devices.loop_end  # the loop sends changed cues straight to it
        app.state.device_host = devices
        address = settings.tracker_address()
        if tracker_sock is None and address is not None:
            supervisor.tracker_sock = tracker_udp.bind(address)
        else:
            supervisor.tracker_sock = tracker_sock
        if supervisor.tracker_sock is not None:  # samples a bridge sends here reach the loop without the hub
            app.state.tracker_udp = "%s:%d" % supervisor.tracker_sock.getsockname()[:2]
            log.info("tracker UDP port: %s (docs/protocol.md)", app.state.tracker_udp)
        supervisor.start()
        trackers = None
        if settings.trackers and supervisor.tracker_sock is not None:  # sources run outside loop and hub
            trackers = TrackerHost(settings.tracker_specs(), app.state.tracker_udp, settings.data_dir)
            trackers.owner = owner
            trackers.on_sources = feed.on_tracker_sources  # a lost tracker makes health degraded
            trackers.start()
        app.state.tracker_host = trackers
        flusher = asyncio.get_running_loop().create_task(_flush_recorder(experiment))
        health = asyncio.get_running_loop().create_task(
            feed.watch_health({"loop": supervisor, "device_host": devices}, each_poll=hub.link.retry_undelivered))
        access.tick()  # a lease that expired while the server was down goes now
        access.on_lease_change(access.lease.snapshot())
        lease_tick = asyncio.get_running_loop().create_task(_tick_lease(access, hub))
        # A full collection over FastAPI's start-up heap pauses this process, event loop and all,
        # for 10-20 ms (measured when the device threads still lived here); freeze it.
        gc.collect()
        gc.freeze()
        yield
        flusher.cancel()
        health.cancel()
        lease_tick.cancel()
        await asyncio.to_thread(experiment.flush)
        if trackers is not None:
            await trackers.stop()
        await supervisor.stop()
        await devices.stop()  # every actuator off first, then the ports are closed
        if rig:
            await asyncio.to_thread(rig.stop)
        if supervisor.tracker_sock is not None:
            supervisor.tracker_sock.close()
        store.close()
        access.close()

    app = FastAPI(title="ViESTac", version=__version__, lifespan=lifespan, docs_url=None, redoc_url=None,
                  description="Networked evaluation suite for wearable tactile displays. "
                              "WebSocket protocol: /ws (docs/protocol.md).")
    app.state.settings = settings
    app.add_middleware(BrowserSafety, **options_for(settings))  # Host, Origin, CORS, security headers
    app.state.hub = hub
    app.state.supervisor = supervisor
    app.state.cpu_plan = cpu_plan
    app.state.rig = rig
    app.state.experiment = experiment
    app.state.paced = paced
    app.state.access = access
    app.state.tracker_udp = None  # "HOST:PORT" once bound
    app.state.tracker_host = None  # the tracker host process's handle, with --tracker
    # every /api operation passes the access guard first (server/api/guard.py)
    for api in (router, experiment_router, access_router, tracker_router, placement_router):
        app.include_router(api, dependencies=[Depends(guard)], responses=GUARD_ERRORS)  # each router says /api
    app.add_middleware(AuditTrail)
    install_access_doc(app)  # /openapi.json says who may call each operation
    install_docs(app)  # /docs and /redoc with local assets (they work without the internet)

    @app.websocket("/ws")
    async def websocket(ws: WebSocket) -> None:
        await hub.fanout.serve(ws)

    if settings.web_root.is_dir():
        app.mount("/", WebClient(directory=settings.web_root), name="web")  # an allowlist, not the folder
    return app
