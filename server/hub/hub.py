"""The WebSocket hub: clients in, state frames out, never in the loop's way.

- Each client has a latest-wins slot for state frames and a small ordered queue for control
  messages (welcome, scene, errors). A slow client only drops its own frames: its sender task
  waits on its own socket, nobody else's (websockets' broadcast guide; issue #1071 upstream).
- A state frame is encoded once per format, not per client.
- Broadcasting wakes the senders in slices of `SLICE` clients and yields to the event loop in
  between, so tracker messages that arrive during a broadcast are read after at most one slice
  instead of after all 64 sends (the probe measured tracker → device p99 4-6 ms at 32+ viewers
  when tracker frames queued behind one broadcast burst).
- Every bad frame gets exactly one `error` reply and the connection stays open.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections import deque
from itertools import count
from typing import Any

from starlette.websockets import WebSocket, WebSocketDisconnect

from devices.capability import CapabilityReport, check
from scenarios import registry
from scenarios.base import ParamError, Trial, describe, find_control
from server.hub.telemetry import LoopTelemetry
from server.wire import codec, messages
from server.wire.codec import WireError

log = logging.getLogger("viestac.hub")

SLICE = 8
HELLO_TIMEOUT_S = 1.0
_CLOSE = object()  # control-queue sentinel: close the connection after what precedes it


class ClientSession:
    def __init__(self, client_id: int, ws: WebSocket, fmt: str):
        self.id = client_id
        self.ws = ws
        self.fmt = fmt
        self.role = "observer"
        self.client_name = ""
        self.welcomed = False
        self.latest: bytes | str | None = None  # latest-wins state slot
        self.control: deque = deque(maxlen=64)  # ordered control messages
        self.wake = asyncio.Event()
        self.close_code: int | None = None
        self.frames_sent = 0
        self.frames_dropped = 0
        self.tracker_count = 0
        self.last_tracker: dict | None = None
        self.errors = 0

    def info(self) -> dict:
        return {"client_id": self.id, "role": self.role, "client": self.client_name, "format": self.fmt,
                "frames_sent": self.frames_sent, "frames_dropped": self.frames_dropped,
                "tracker_count": self.tracker_count, "last_tracker": self.last_tracker, "errors": self.errors}


class ScenarioRefused(Exception):
    """A scenario switch that the capability check refuses (no device shows what it is about)."""

    def __init__(self, report: CapabilityReport):
        super().__init__(report.message)
        self.report = report


class Hub:
    def __init__(self, *, server_name: str, tick_hz: int, state_hz: float):
        self.server_name = server_name
        self.tick_hz = tick_hz
        self.state_hz = state_hz
        self.sessions: dict[int, ClientSession] = {}
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
        self.device_profiles: dict = {}  # name → DeviceProfile as the devices identified themselves (device host)
        self.tracker_applied: deque[list] = deque(maxlen=4096)  # [client_id, seq, t_ms, recv_ns, applied_ns]
        self.log_records: deque[dict] = deque(maxlen=200)
        self._frames: dict[str, bytes | str] = {}
        self._frame_seq = 0
        self._broadcaster: asyncio.Task | None = None
        self.send_to_loop = lambda record: False  # wired by the app to the loop supervisor
        self.scenario_state: dict | None = None  # what the loop runs: id, params, seed, trial
        self.scenario_cls = None
        self.on_scenario = lambda state: None  # wired by the app: a restarted loop resumes this
        self.record_every = 0  # trajectory sampling asked of the loop (experiment recorder); 0 = off
        self.listeners: list = []  # called with every loop record after the hub handled it (the recorder)

    # ---- records from the loop process -------------------------------------------------
    def on_loop_record(self, record: list) -> None:
        kind = record[0]
        if kind == "state":
            self._on_state(record[1])
        elif kind == "scene":
            self._on_scene(record[1], record[2])
        elif kind == "hello":
            self.loop_info = record[1]
            self.telemetry.rt = bool(record[1].get("rt"))
            if self._device_report is not None:  # a (re)started loop learns the refusals again
                self.send_to_loop(["devices", self._device_report])
            if self.record_every:
                self.send_to_loop(["record", self.record_every])
        elif kind == "scenario":
            self.scenario_state = record[1]
            self.scenario_cls = registry.resolve(record[1]["id"]).factory
            self.on_scenario(record[1])
        elif kind == "log":
            level = logging.ERROR if record[1] == "error" else logging.WARNING
            log.log(level, "loop: %s", record[2])
            self.log_records.append({"t": time.time(), "level": record[1], "text": record[2]})
        for listener in self.listeners:
            listener(record)

    def set_recording(self, every_n_ticks: int) -> None:
        """Ask the loop for trajectory rows every Nth tick (0: none); kept across loop restarts."""
        self.record_every = every_n_ticks
        self.send_to_loop(["record", every_n_ticks])

    def _on_scene(self, scene: dict, scene_hash: str) -> None:
        self.scene, self.scene_hash = scene, scene_hash
        message = messages.scene_message(scene, scene_hash)
        self._scene_frames = {fmt: codec.encode(message, fmt) for fmt in codec.FORMATS}
        for s in self.sessions.values():
            if s.welcomed:
                s.control.append(self._scene_frames[s.fmt])
                s.wake.set()

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
        if report != self._device_report:
            self._device_report = report
            self.send_to_loop(["devices", report])
            for listener in self.listeners:
                listener(["devices", report])

    def _on_state(self, rec: dict) -> None:
        # The devices got this tick's cues already: the loop sent them to the device host's feed.
        self.telemetry.add(rec["samples"])
        self.telemetry.resyncs = rec.get("resyncs", 0)
        if rec["trackers"]:
            self.tracker_applied.extend(rec["trackers"])
        self.states_received += 1
        message = messages.state_message(
            frame=rec["frame"], tick=rec["tick"], t=rec["t"], scene=self.scene_hash, hip=rec["hip"],
            proxy=rec["proxy"], force=rec["force"], contact=rec["contact"], contacts=rec["contacts"],
            objects=rec["objects"], cues=rec["cues"], hud=rec["hud"], values=rec["values"],
            telemetry=self.telemetry_summary(), visible=rec.get("visible"), events=rec.get("events"),
            scales=rec.get("scales"))
        self.last_state = message
        formats = {s.fmt for s in self.sessions.values() if s.welcomed}
        self._frames = {fmt: codec.encode(message, fmt) for fmt in formats}
        self._frame_seq += 1
        if self._frames and (self._broadcaster is None or self._broadcaster.done()):
            self._broadcaster = asyncio.get_running_loop().create_task(self._broadcast())

    async def _broadcast(self) -> None:
        delivered = 0
        while delivered != self._frame_seq:
            delivered = self._frame_seq
            # Participants and operators first: the frame showing their own hand must not wait behind
            # every viewer's send (docs/performance.md, "Tracker → state round trip").
            for i, s in enumerate(sorted(self.sessions.values(), key=lambda s: s.role == "observer")):
                frame = self._frames.get(s.fmt)
                if not s.welcomed or frame is None:
                    continue
                if s.latest is not None:
                    s.frames_dropped += 1
                s.latest = frame
                s.wake.set()
                if (i + 1) % SLICE == 0:
                    await asyncio.sleep(0)  # let tracker reads in between slices

    # ---- one WebSocket connection -----------------------------------------------------
    async def serve(self, ws: WebSocket) -> None:
        offered = ws.scope.get("subprotocols") or []
        chosen = next((p for p in offered if p in codec.SUBPROTOCOLS), None)
        await ws.accept(subprotocol=chosen)
        s = ClientSession(next(self._ids), ws, codec.SUBPROTOCOLS.get(chosen, "msgpack"))
        self.sessions[s.id] = s
        sender = asyncio.create_task(self._sender(s))
        try:
            try:
                first = await asyncio.wait_for(ws.receive(), HELLO_TIMEOUT_S)
            except asyncio.TimeoutError:
                first = None
            if first is not None and first["type"] == "websocket.disconnect":
                return
            if first is not None:
                self._on_frame(s, first, first_frame=True)
            if not s.welcomed and s.close_code is None:
                self._welcome(s)
            while s.close_code is None:
                message = await ws.receive()
                if message["type"] == "websocket.disconnect":
                    return
                self._on_frame(s, message)
            # We are closing (e.g. unsupported version): let the sender flush the error first.
            await asyncio.wait_for(asyncio.shield(sender), 2.0)
        except (WebSocketDisconnect, RuntimeError, asyncio.TimeoutError):
            pass
        finally:
            self.sessions.pop(s.id, None)
            sender.cancel()

    async def _sender(self, s: ClientSession) -> None:
        try:
            while True:
                await s.wake.wait()
                s.wake.clear()
                while s.control:
                    item = s.control.popleft()
                    if item is _CLOSE:
                        await s.ws.close(code=s.close_code or 1000)
                        return
                    await self._send(s, item)
                frame, s.latest = s.latest, None
                if frame is not None:
                    await self._send(s, frame)
                    s.frames_sent += 1
        except (WebSocketDisconnect, RuntimeError, OSError):
            return

    @staticmethod
    async def _send(s: ClientSession, data: bytes | str) -> None:
        if isinstance(data, bytes):
            await s.ws.send_bytes(data)
        else:
            await s.ws.send_text(data)

    def _welcome(self, s: ClientSession) -> None:
        s.welcomed = True
        s.control.append(codec.encode(messages.welcome(s.id, s.role, self.server_name, self.tick_hz,
                                                       self.state_hz, s.fmt), s.fmt))
        if self._scene_frames:
            s.control.append(self._scene_frames[s.fmt])
        s.wake.set()

    def _error(self, s: ClientSession, code: str, text: str) -> None:
        s.errors += 1
        s.control.append(codec.encode(messages.error(code, text), s.fmt))
        s.wake.set()

    def _on_frame(self, s: ClientSession, frame: dict[str, Any], first_frame: bool = False) -> None:
        data = frame.get("bytes")
        if data is None:
            data = frame.get("text")
        try:
            if data is None:
                raise WireError("bad_encoding", "empty frame")
            message = messages.parse_client_message(codec.decode(data, s.fmt))
        except WireError as exc:
            self._error(s, exc.code, exc.message)
            return
        if isinstance(message, messages.Hello):
            self._on_hello(s, message, first_frame)
        elif s.role == "observer":
            self._error(s, "forbidden", f"an observer may not send '{frame_type(message)}' messages")
        elif isinstance(message, messages.Tracker):
            s.tracker_count += 1
            s.last_tracker = {"seq": message.seq, "t": message.t_ms, "pos": list(message.pos)}
            record = ["tracker", s.id, message.seq, message.t_ms, list(message.pos),
                      list(message.quat) if message.quat else None, time.monotonic_ns()]
            if not self.send_to_loop(record):
                self._error(s, "busy", "the loop's input mailbox is full; tracker sample dropped")
        elif isinstance(message, messages.Input):
            try:
                self.command(message.key, message.action, message.value, role=s.role, client_id=s.id)
            except PermissionError as exc:
                self._error(s, "forbidden", str(exc))
            except ParamError as exc:
                self._error(s, "bad_message", str(exc))
            except BusyError as exc:
                self._error(s, "busy", str(exc))

    # ---- scenario control (WebSocket input and REST share these) -----------------------
    def command(self, key: str, action: str, value=None, *, role: str = "operator", client_id: int = 0) -> None:
        """A key or experimenter command for the running scenario, checked against its CONTROLS:
        operator-only commands from other roles are forbidden, a command's value must fit its
        spec. Keys the scenario does not declare pass through (keyboards send every key)."""
        control = find_control(self.scenario_cls.CONTROLS, key) if self.scenario_cls else None
        if control is None:
            if value is not None:
                raise ParamError(f"the running scenario has no command {key!r} that takes a value")
        else:
            if control.who == "operator" and role != "operator":
                raise PermissionError(f"{key!r} is an experimenter command; a {role} may not send it")
            if control.value is None and value is not None:
                raise ParamError(f"{key!r} takes no value")
            if control.value is not None and action != "up":
                if value is None:
                    raise ParamError(f"{key!r} needs a value: {control.value.doc}")
                value = control.value.check(value, key)
        record = ["input", client_id, key, action] + ([value] if value is not None else [])
        if not self.send_to_loop(record):
            raise BusyError("the loop's input mailbox is full; input dropped")

    def capability(self, scenario_cls=None) -> CapabilityReport:
        cls = scenario_cls or self.scenario_cls
        return check(cls.id, tuple(cls.REQUIRES), self.device_profiles)

    def switch_scenario(self, name: str, params: dict | None = None, seed: int = 0, force: bool = False) -> dict:
        """Ask the loop to run another scenario (registry.UnknownScenario, ParamError,
        ScenarioRefused on bad requests; nothing is sent then)."""
        spec = registry.resolve(name)
        checked = registry.check_scenario_params(spec, params or {})
        registry.create(spec.id, **checked)  # constructing is cheap and finds what per-parameter checks cannot
        report = self.capability(spec.factory)
        if not report.ok and not force:
            raise ScenarioRefused(report)
        if not self.send_to_loop(["scenario", spec.id, checked, seed]):
            raise BusyError("the loop's input mailbox is full; try again")
        # the mailbox is ordered: a trial or command sent next is for the new scenario
        self.scenario_cls = spec.factory
        return {"id": spec.id, "params": checked, "seed": seed, "capability": report.to_dict()}

    def set_trial(self, phase: str | None, params: dict | None = None, index: int = 0) -> dict | None:
        """Start a trial of the running scenario (phase None ends it)."""
        trial = None
        if phase is not None:
            if self.scenario_cls is None:
                raise ParamError("no scenario is running yet")
            trial = Trial.parse(self.scenario_cls.TRIAL_PARAMS, phase, params, index).to_dict()
        if not self.send_to_loop(["trial", trial]):
            raise BusyError("the loop's input mailbox is full; try again")
        return trial

    def scenario_info(self) -> dict:
        if self.scenario_cls is None or self.scenario_state is None:
            return {}
        # the scene hash names the scene this scenario announced (the loop sends the scene first)
        return {**self.scenario_state, "scene": self.scene_hash, "info": describe(self.scenario_cls),
                "capability": self.capability().to_dict()}

    def _on_hello(self, s: ClientSession, hello: messages.Hello, first_frame: bool) -> None:
        if hello.version != messages.PROTOCOL_VERSION:
            self._error(s, "unsupported_version",
                        f"protocol version {hello.version} is not supported; this server speaks v{messages.PROTOCOL_VERSION}")
            s.close_code = 1002
            s.control.append(_CLOSE)
            s.wake.set()
            return
        if s.welcomed:
            self._error(s, "bad_message", "hello must be the first message of a connection")
            return
        s.role, s.client_name = hello.role, hello.client
        self._welcome(s)

    def clients(self) -> list[dict]:
        return [s.info() for s in self.sessions.values()]


class BusyError(RuntimeError):
    """The loop's mailbox is full; the request was dropped."""


def frame_type(message) -> str:
    return {messages.Tracker: "tracker", messages.Input: "input"}.get(type(message), "?")
