"""The WebSocket hub: clients in, state frames out, never in the loop's way.

The asyncio shell around the clients' protocol sessions (server/hub/session.py, I/O-free: hello,
roles, errors, what each client is sent and in which order) and the fan-out of the loop's records:
- Each client has a sender task that takes what its session has queued: control messages in
  order, then the latest state frame (latest-wins). A slow client only drops its own frames: its
  sender waits on its own socket, nobody else's (websockets' broadcast guide; issue #1071 upstream).
- A state frame is encoded once per format, not per client.
- Broadcasting wakes the senders in slices of `SLICE` clients and yields to the event loop in
  between, so tracker messages that arrive during a broadcast are read after at most one slice
  instead of after all 64 sends (the design measurements, docs/reference.md, saw tracker → device
  p99 4-6 ms at 32+ viewers when tracker frames queued behind one broadcast burst).
- One thread owns the hub, the event loop's (server/hub/owner.py).
- Health (server/hub/health.py) is fed from here: the loop's records, the device reports, the
  child processes' starts and exits; it is evaluated every `HEALTH_EVERY_S` and on every record
  that can change it, and each client is sent a `health` message when the status or the set of
  reason codes changes.
- Access control (server/auth, `access_control`): each session authenticates its hello's token
  and checks every message against the policy and the control lease through a `Gate`; the lease
  reaches every client as a `lease` message (`set_lease`), and a client that drove the HIP and
  may no longer lets go of it (`tracker_gone`), so the HIP goes home. One token holds at most
  MAX_CONNECTIONS_PER_TOKEN connections.
- A participant's study answers (v1.5 `answer`) go to `on_answer` on a worker thread (the engine
  writes SQLite), and its refusal back to the client; what a session's participant is asked
  (`publish_ask`, from the engine's changes) reaches that session's participant connections, and
  a participant that connects later gets the latest (`participant_view`, read on a worker thread).
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections import deque
from itertools import count

from starlette.websockets import WebSocket, WebSocketDisconnect

from devices.capability import CapabilityReport, showing
from server.core.scenario import ParamError
from server.hub.control import BusyError, ScenarioControl
from server.hub.event_log import EventLog
from server.hub.health import HOST_DOWN, Health, HealthReport
from server.hub.owner import Owner
from server.hub.session import CLOSED, Close, Command, Gate, ParticipantAnswer, ServerInfo, Session, ToLoop
from server.hub.telemetry import LoopTelemetry
from server.ipc.records import (DeviceReport, FailSafe, Fault, Hello, Log, Malformed, Record, RecordEvery,
                                Recovered, ScenarioAnnounce, SceneAnnounce, State)
from server.wire import codec, messages

log = logging.getLogger("viestac.hub")

SLICE = 8
HEALTH_EVERY_S = 0.025  # a fault shows in health within 100 ms: 50 ms stall rule + this + a poll
FLUSH_BEFORE_CLOSE_S = 2.0
MAX_CONNECTIONS_PER_TOKEN = 256  # 64 viewers of a bench run, with room; a leaked token cannot open thousands


class Connection:
    """One client's socket, its protocol session and its sender's wake-up."""

    def __init__(self, ws: WebSocket, session: Session):
        self.ws = ws
        self.session = session
        self.wake = asyncio.Event()


class Hub:
    def __init__(self, *, server_name: str, tick_hz: int, state_hz: float, overrun_threshold: int = 10):
        self.health = Health(overrun_threshold=overrun_threshold)
        self.health_report = HealthReport("starting")
        self._health_frames: dict[str, bytes | str] = {}
        self.device_statuses: dict[str, str] = {}  # name → status as the device host last reported it
        self._device_profiles: dict = {}
        # scenario control (server/hub/control.py); send_to_loop and device_profiles are wired later
        self.control = ScenarioControl(lambda record: self.send_to_loop(record), lambda: self.device_profiles,
                                       lambda: self.device_statuses)
        self.server_name = server_name
        self.tick_hz = tick_hz
        self.state_hz = state_hz
        self.owner = Owner("the hub")  # the app shares one with the supervisor and the device host
        self._access_control = None  # server.auth.AccessControl; without one no client is admitted
        self._lease_frames: dict[str, bytes | str] = {}
        self.connections: dict[int, Connection] = {}
        self._ids = count(1)
        self.scene: dict | None = None
        self.scene_hash = ""
        self._scene_frames: dict[str, bytes | str] = {}
        self.telemetry = LoopTelemetry(tick_hz=tick_hz)
        self._telemetry_summary: dict = self.telemetry.window()
        self._telemetry_at = 0.0
        self.loop_info: dict = {}
        self.last_state: dict | None = None
        self.states_received = 0
        self._device_report: dict | None = None
        self._tracking_lost = False  # the last state record listed a lost tracker source
        self.tracker_applied: deque[list] = deque(maxlen=4096)  # [client_id, seq, t_ms, recv_ns, applied_ns]
        self.log_records: deque[dict] = deque(maxlen=200)
        self._frames: dict[str, bytes | str] = {}
        self._frames_scene = ""  # the scene the current state frames name
        self.event_log = EventLog()  # the state frames' events, numbered (server/hub/event_log.py)
        self._frames_events = 0  # the number of the current state frames' last event
        self._frame_seq = 0
        self._broadcaster: asyncio.Task | None = None
        self.send_to_loop = lambda record: False  # wired by the app to the loop supervisor
        self.scenario_state: dict | None = None  # what the loop runs: id, params, seed, trial
        self.scenario_cls = None
        self.on_scenario = lambda state: None  # wired by the app: a restarted loop resumes this
        self.record_every = 0  # trajectory sampling asked of the loop (experiment recorder); 0 = off
        self.undelivered: deque[Record] = deque(maxlen=1024)  # records for the loop that must not be lost (retried)
        self.listeners: list = []  # called with every loop record after the hub handled it (the recorder)
        # participants' answers (wired by the app to the experiment engine; worker thread): None when
        # recorded, else (error code, message) for the client
        self.on_answer = lambda answer: ("conflict", "this server records no study answers")
        self.participant_view = lambda session_id: None  # a session's `ask` view (worker thread), or None
        self._asks: dict[str, dict[str, bytes | str]] = {}  # session → its latest `ask` per format
        self._tasks: set[asyncio.Task] = set()  # answers and reads under way (held: a bare task may be collected)

    # ---- access control (server/auth) ------------------------------------------------------------
    @property
    def access_control(self):
        return self._access_control

    @access_control.setter
    def access_control(self, access) -> None:
        """The server's AccessControl: every hello's token is checked against it, and its lease
        changes (from any thread: REST runs lease calls on worker threads) reach every client."""
        self._access_control = access
        access.on_lease_change = self._lease_changed_anywhere
        self.set_lease(access.lease.snapshot())

    def _lease_changed_anywhere(self, snapshot: dict) -> None:
        if self.owner.here:
            self.set_lease(snapshot)
        else:  # a worker thread must not wait for the event loop, nor touch the sessions
            self.owner.loop.call_soon_threadsafe(self.set_lease, snapshot)

    def set_lease(self, snapshot: dict) -> None:
        """The control lease now (Lease.snapshot()): every client is sent it, and clients that may
        no longer drive the HIP leave it."""
        self.owner.check()
        message = messages.lease(snapshot)
        self._lease_frames = {fmt: codec.encode(message, fmt) for fmt in codec.FORMATS}
        for c in list(self.connections.values()):
            self._forward(c, c.session.set_lease(self._lease_frames))
            c.wake.set()

    def _gate(self, ws: WebSocket) -> Gate:
        access = self._access_control
        if access is None:
            return CLOSED
        client = ws.scope.get("client")
        peer = client[0] if client else "unknown"
        return Gate(lambda secret: access.authenticate(secret, peer), lambda: access.lease, self._admit)

    def _admit(self, who) -> str | None:
        n = sum(1 for c in self.connections.values()
                if c.session.identity is not None and c.session.identity.token_id == who.token_id)
        if n >= MAX_CONNECTIONS_PER_TOKEN:
            return f"token {who.token_id} already has {n} connections open (at most {MAX_CONNECTIONS_PER_TOKEN})"
        return None

    # ---- records from the loop process -------------------------------------------------
    def on_loop_record(self, record: Record) -> None:
        self.owner.check()
        match record:
            case State():
                self._on_state(record)
            case Fault(failures, _, error):  # a tick failed (LoopCore; at most once per 100 failing ticks)
                self.health.fault(time.monotonic(), failures, error)
                self.check_health()
            case Recovered(_, failures):
                self.health.recovered(time.monotonic(), failures)
                self.check_health()
            case SceneAnnounce(scene, scene_hash):
                self._on_scene(scene, scene_hash)
            case Hello(info):
                self.loop_info = info
                self.control.loop_restarted()
                self.telemetry.rt = bool(info.get("rt"))
                if self._device_report is not None:  # a (re)started loop learns the refusals again
                    self.send_to_loop(DeviceReport(self._device_report))
                if self.record_every:
                    self.send_to_loop(RecordEvery(self.record_every))
            case ScenarioAnnounce(info):
                self.scenario_state = info
                self.control.announced(info)
                self._update_needs()
                self.on_scenario(info)
            case Log(level, text):
                log.log(logging.ERROR if level == "error" else logging.WARNING, "loop: %s", text)
                self.log_records.append({"t": time.time(), "level": level, "text": text})
            case FailSafe():
                pass  # the recorder notes it (listeners); the fault record tells health
            case Malformed(error):
                log.error("a bad record from the loop: %s", error)
                return
        for listener in self.listeners:
            listener(record)

    def set_recording(self, every_n_ticks: int) -> None:
        """Ask the loop for trajectory rows every Nth tick (0: none); kept across loop restarts."""
        self.owner.check()
        self.record_every = every_n_ticks
        self.send_to_loop(RecordEvery(every_n_ticks))

    def _on_scene(self, scene: dict, scene_hash: str) -> None:
        self.scene, self.scene_hash = scene, scene_hash
        message = messages.scene_message(scene, scene_hash)
        self._scene_frames = {fmt: codec.encode(message, fmt) for fmt in codec.FORMATS}
        for c in self.connections.values():
            c.session.set_scene(scene_hash, self._scene_frames)
            c.wake.set()

    def telemetry_summary(self) -> dict:
        now = time.monotonic()
        if now - self._telemetry_at > 0.5:  # percentiles over 10 s of ticks: at most twice a second
            self._telemetry_summary = self.telemetry.window()
            self._telemetry_at = now
        return self._telemetry_summary

    # ---- devices ----------------------------------------------------------------------------
    def on_device_report(self, report: dict) -> None:
        """The rig's report (device host process): refusals no device shows, and each device's
        status. The loop learns it (TickContext.refusals), listeners record it."""
        self.owner.check()
        statuses = report.get("status") or {}
        if statuses != self.device_statuses:
            self.device_statuses = dict(statuses)
            self.health.devices(statuses, time.monotonic())
            self.check_health()
        if report != self._device_report:
            self._device_report = report
            record = DeviceReport(report)
            self.send_to_loop(record)
            for listener in self.listeners:
                listener(record)

    def _on_state(self, state: State) -> None:
        # The devices got this tick's cues already: the loop sent them to the device host's feed.
        timing, view = state.timing, state.view
        overruns = self.telemetry.add(timing.samples)
        now = time.monotonic()
        self.health.state(now, timing.failures, overruns)
        lost = view["tracking"]["lost"]
        if lost or self._tracking_lost:  # a tracker source stopped, or it has just come back
            tools = [t["name"] for t in view["tools"] if t.get("lost")]
            self._tracking_lost = bool(lost)
            if self.health.tracking(lost, tools, now):
                self.check_health()
        self.telemetry.resyncs = timing.resyncs or 0
        if state.recorded.trackers:
            self.tracker_applied.extend(state.recorded.trackers)
        self.states_received += 1
        message = messages.state_message(view, self.telemetry_summary())  # names the scene the loop simulated
        self.last_state = message
        self._frames_events = self.event_log.add(message["events"])  # a client that misses it still gets these
        formats = {c.session.fmt for c in self.connections.values() if c.session.welcomed}
        self._frames = {fmt: codec.encode(message, fmt) for fmt in formats}
        self._frames_scene = message["scene"]  # the scene the frame names, known without decoding it
        self._frame_seq += 1
        if self._frames and (self._broadcaster is None or self._broadcaster.done()):
            self._broadcaster = asyncio.get_running_loop().create_task(self._broadcast())

    async def _broadcast(self) -> None:
        delivered = 0
        while delivered != self._frame_seq:
            delivered = self._frame_seq
            # Participants and operators first: the frame showing their own hand must not wait behind
            # every viewer's send (docs/performance.md, "Tracker → state round trip (/ws)").
            for i, c in enumerate(sorted(self.connections.values(), key=lambda c: c.session.role == "observer")):
                frame = self._frames.get(c.session.fmt)
                if not c.session.welcomed or frame is None:
                    continue
                c.session.offer_state(frame, self._frames_scene, self.last_state, self._frames_events)
                c.wake.set()
                if (i + 1) % SLICE == 0:
                    await asyncio.sleep(0)  # let tracker reads in between slices

    # ---- one WebSocket connection -----------------------------------------------------
    async def serve(self, ws: WebSocket) -> None:
        self.owner.check()
        offered = ws.scope.get("subprotocols") or []
        chosen = next((p for p in offered if p in codec.SUBPROTOCOLS), None)
        await ws.accept(subprotocol=chosen)
        server = ServerInfo(self.server_name, self.tick_hz, self.state_hz)
        session = Session(next(self._ids), codec.SUBPROTOCOLS.get(chosen, "msgpack"), server, time.monotonic_ns(),
                          gate=self._gate(ws), events=self.event_log)
        if self._scene_frames:
            session.set_scene(self.scene_hash, self._scene_frames)
        if self._health_frames:
            session.set_health(self._health_frames)
        if self._lease_frames:
            session.set_lease(self._lease_frames)
        c = Connection(ws, session)
        self.connections[session.id] = c
        sender = asyncio.create_task(self._sender(c))
        try:
            while not session.closing:
                wait = session.hello_wait_s(time.monotonic_ns())
                try:
                    message = await (ws.receive() if wait is None else asyncio.wait_for(ws.receive(), wait))
                except asyncio.TimeoutError:
                    session.hello_deadline_passed(time.monotonic_ns())
                    c.wake.set()
                    continue
                if message["type"] == "websocket.disconnect":
                    return
                data = message.get("bytes")
                if data is None:
                    data = message.get("text")
                welcomed = session.welcomed
                self._forward(c, session.receive(data, time.monotonic_ns()))
                if not welcomed and session.asks_for is not None:
                    self._offer_ask(c)
                c.wake.set()
            # We are closing (e.g. unsupported version): let the sender flush the error first.
            await asyncio.wait_for(asyncio.shield(sender), FLUSH_BEFORE_CLOSE_S)
        except (WebSocketDisconnect, RuntimeError, asyncio.TimeoutError):
            pass
        finally:
            self.connections.pop(session.id, None)
            sender.cancel()
            self._forward(c, session.disconnected())

    async def _sender(self, c: Connection) -> None:
        try:
            while True:
                await c.wake.wait()
                c.wake.clear()
                while (item := c.session.next_frame()) is not None:
                    if isinstance(item, Close):
                        await c.ws.close(code=item.code)
                        return
                    if isinstance(item, bytes):
                        await c.ws.send_bytes(item)
                    else:
                        await c.ws.send_text(item)
        except (WebSocketDisconnect, RuntimeError, OSError):
            return

    # ---- study answers (protocol v1.5 `ask`, `answer`) ---------------------------------------
    def publish_ask(self, session_id: str, view: dict | None) -> None:
        """What `session_id`'s participant is asked now: to its participant connections."""
        self.owner.check()
        if view is None:
            return
        message = messages.ask(view)
        frames = self._asks[session_id] = {fmt: codec.encode(message, fmt) for fmt in codec.FORMATS}
        for c in list(self.connections.values()):
            if c.session.asks_for == session_id:
                c.session.set_ask(frames)
                c.wake.set()

    def _offer_ask(self, c: Connection) -> None:
        """A participant of a session was welcomed: its latest `ask`, read first if need be."""
        session_id = c.session.asks_for
        frames = self._asks.get(session_id)
        if frames is not None:
            c.session.set_ask(frames)
            return

        async def read() -> None:
            try:
                view = await asyncio.to_thread(self.participant_view, session_id)
            except Exception:  # an unknown or unreadable session: the page simply gets no `ask`
                log.exception("could not read what session %s asks", session_id)
                return
            if session_id not in self._asks:  # a change published meanwhile is newer
                self.publish_ask(session_id, view)
        self._spawn(read())

    def _spawn(self, coro) -> None:
        task = asyncio.get_running_loop().create_task(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _answer(self, c: Connection, answer: ParticipantAnswer) -> None:
        try:
            refusal = await asyncio.to_thread(self.on_answer, answer)
        except Exception:
            log.exception("a participant's answer failed")
            refusal = ("busy", "the answer could not be recorded; send it again")
        if refusal is not None:
            c.session.reply_error(*refusal)
            c.wake.set()

    def _forward(self, c: Connection, events: list[ToLoop | Command | ParticipantAnswer]) -> None:
        """What a client's session asks of the loop; refusals go back to the client as errors."""
        for event in events:
            if isinstance(event, ParticipantAnswer):
                self._spawn(self._answer(c, event))
                continue
            if isinstance(event, ToLoop):
                if not self.send_to_loop(event.record):
                    if event.busy:
                        c.session.reply_error("busy", event.busy)
                    else:  # nobody to tell (a client left: tracker_gone): it must still arrive
                        self.undelivered.append(event.record)
                continue
            if event.role == "operator" and self.control.is_operator_command(event.key):
                refusal = c.session.refusal("input:operator")  # experimenter commands need the lease
                if refusal is not None:
                    c.session.reply_error("forbidden", refusal)
                    continue
            try:
                self.command(event.key, event.action, event.value, role=event.role, client_id=event.client_id)
            except PermissionError as exc:
                c.session.reply_error("forbidden", str(exc))
            except ParamError as exc:
                c.session.reply_error("bad_message", str(exc))
            except BusyError as exc:
                c.session.reply_error("busy", str(exc))

    # ---- health (server/hub/health.py) ------------------------------------------------------
    @property
    def device_profiles(self) -> dict:
        """name → DeviceProfile as the devices identified themselves (device host)."""
        return self._device_profiles

    @device_profiles.setter
    def device_profiles(self, profiles: dict) -> None:
        self._device_profiles = profiles
        self._update_needs()

    def _update_needs(self) -> None:
        """Which devices show each dimension the running scenario requires (for device_missing)."""
        cls = self.control.scenario_cls
        if cls is not None:
            self.health.needs(cls.id, showing(tuple(cls.REQUIRES), self._device_profiles))

    def on_tracker_sources(self, sources: list[dict]) -> None:
        """The tracker host's health of each configured source (every 0.1 s, and when it exits)."""
        self.owner.check()
        if self.health.trackers(sources, time.monotonic()):
            self.check_health()

    def on_child_start(self, what: str) -> None:
        """A child process ("loop" or "device_host") started (the supervisor's on_start hook)."""
        now = time.monotonic()
        (self.health.loop_started if what == "loop" else self.health.device_host_started)(now)
        self.check_health()

    def on_child_exit(self, what: str, returncode: int | None) -> None:
        """A child process exited (the supervisor's on_exit hook)."""
        now = time.monotonic()
        if what == "loop":
            self.health.loop_exited(now, returncode)
        else:
            self.health.device_host_exited(now, returncode)
            # nobody drives them now; the restarted host reports them again
            self.device_statuses = {name: HOST_DOWN for name in self._device_profiles}
        self.check_health()

    async def watch_health(self, children: dict) -> None:
        """Every HEALTH_EVERY_S: poll the child processes (`children`: "loop" / "device_host" →
        ChildProcess), then evaluate health. The poll stands in until the children report their
        starts and exits themselves; on_child_start/on_child_exit take either."""
        seen: dict[str, object] = {what: None for what in children}  # the process last seen running
        while True:
            for what, child in children.items():
                proc = child.proc if child.alive else None
                if proc is not seen[what]:
                    if seen[what] is not None:  # it died (and may be running again already: a new process)
                        self.on_child_exit(what, seen[what].returncode)
                    if proc is not None:
                        self.on_child_start(what)
                    seen[what] = proc
            self.retry_undelivered()
            self.check_health()
            await asyncio.sleep(HEALTH_EVERY_S)

    def retry_undelivered(self) -> None:
        """Records the loop's full mailbox refused and nobody could be told of, in order."""
        self.owner.check()
        while self.undelivered and self.send_to_loop(self.undelivered[0]):
            self.undelivered.popleft()

    def check_health(self) -> HealthReport:
        """Evaluate health now; clients are sent a `health` message when the status or the set of
        reason codes changed."""
        report = self.health.evaluate(time.monotonic())
        previous, self.health_report = self.health_report, report
        if not self._health_frames or (report.status, report.codes) != (previous.status, previous.codes):
            if report.status != previous.status:
                log.log(logging.INFO if report.status == "ok" else logging.WARNING, "health: %s%s", report.status,
                        "".join(f"; {r['message']}" for r in report.reasons))
            message = messages.health(report.status, list(report.reasons))
            self._health_frames = {fmt: codec.encode(message, fmt) for fmt in codec.FORMATS}
            for c in self.connections.values():
                c.session.set_health(self._health_frames)
                c.wake.set()
        return report

    # ---- scenario control (WebSocket input and REST share these; server/hub/control.py) ----
    @property
    def scenario_cls(self):
        return self.control.scenario_cls

    @scenario_cls.setter
    def scenario_cls(self, cls) -> None:
        self.control.scenario_cls = cls

    def command(self, key: str, action: str, value=None, *, role: str = "operator", client_id: int = 0) -> None:
        """A key or experimenter command for the running scenario (ScenarioControl.command)."""
        self.control.command(key, action, value, role=role, client_id=client_id)

    def capability(self, scenario_cls=None) -> CapabilityReport:
        return self.control.capability(scenario_cls)

    def switch_scenario(self, name: str, params: dict | None = None, seed: int = 0, force: bool = False) -> dict:
        """Ask the loop to run another scenario (registry.UnknownScenario, ParamError,
        ScenarioRefused, BusyError on bad requests; nothing is sent then)."""
        return self.control.switch_scenario(name, params, seed, force)

    def set_trial(self, phase: str | None, params: dict | None = None, index: int = 0,
                  force: bool = False) -> dict | None:
        """Start a trial of the running scenario (phase None ends it); DeviceMissing when a device
        it needs is not connected, unless `force`."""
        return self.control.set_trial(phase, params, index, force)

    def require_devices(self, scenario: str | None = None, force: bool = False) -> None:
        """DeviceMissing when a device `scenario` (default: the running one) needs is not connected."""
        self.control.require_devices(scenario, force)

    @property
    def scenario_target(self) -> dict | None:
        """What the loop runs once the switches sent to it land (ScenarioControl.target)."""
        return self.control.target(self.scenario_state)

    def scenario_info(self) -> dict:
        # the scene hash names the scene this scenario announced (the loop sends the scene first)
        return self.control.info(self.scenario_state, self.scene_hash)

    def clients(self) -> list[dict]:
        return [c.session.info() for c in self.connections.values()]


