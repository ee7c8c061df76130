"""The fan-out: every client's socket, its protocol session and sender, and what all clients are
sent (state, scene, health, lease frames), never in the loop's way.

- Each client has a sender task that takes what its session has queued: control messages in
  order, then the latest state frame (latest-wins). A slow client only drops its own frames: its
  sender waits on its own socket, nobody else's (websockets' broadcast guide; issue #1071 upstream).
- A frame is encoded once per format, not per client, and at most as often as the frame ceiling
  lets (server/hub/frame_ceiling.py: `state_hz` + 60 a second): a loop publishing every tick
  (cues changing in a storm of contacts) costs the hub one encode per ceiling slot, not one per
  tick and viewer.
- Broadcasting wakes the senders in slices of `SLICE` clients and yields to the event loop in
  between, so tracker messages that arrive during a broadcast are read after at most one slice
  instead of after all 64 sends (the design measurements, docs/reference.md, saw tracker → device
  p99 4-6 ms at 32+ viewers when tracker frames queued behind one broadcast burst).
- Access control (server/auth): each session authenticates its hello's token and checks every
  message against the policy and the control lease through a `Gate`; the lease reaches every
  client as a `lease` message (`set_lease`), and a client that drove the HIP and may no longer
  lets go of it (`tracker_gone`), so the HIP goes home. One token holds at most
  MAX_CONNECTIONS_PER_TOKEN connections.

What a session asks of the loop, the scenario or the study comes out of it as events, handed to
the injected `forward(connection, events)` (the hub routes them).
"""

from __future__ import annotations

import asyncio
import time
from itertools import count
from typing import Callable

from starlette.websockets import WebSocket, WebSocketDisconnect

from server.hub.event_log import EventLog
from server.hub.frame_ceiling import FrameCeiling
from server.hub.owner import Owner
from server.hub.outbox import Close
from server.hub.session import CLOSED, Gate, ServerInfo, Session, gate_of
from server.wire import codec, messages

SLICE = 8
FLUSH_BEFORE_CLOSE_S = 2.0
MAX_CONNECTIONS_PER_TOKEN = 256  # 64 viewers of a bench run, with room; a leaked token cannot open thousands


class Connection:
    """One client's socket, its protocol session and its sender's wake-up."""

    def __init__(self, ws: WebSocket, session: Session):
        self.ws = ws
        self.session = session
        self.wake = asyncio.Event()


class Fanout:
    """`access`: the server's AccessControl (None: no client is admitted). `forward(c, events)`:
    what a session asks of the loop or the scenario. `on_welcomed(c)`: a client was just welcomed."""

    def __init__(self, owner: Owner, server: ServerInfo, *, access=None,
                 forward: Callable[[Connection, list], None], on_welcomed: Callable[[Connection], None]):
        self.owner = owner
        self.server = server
        self.access = access
        self.forward = forward
        self.on_welcomed = on_welcomed
        self.connections: dict[int, Connection] = {}
        self._ids = count(1)
        self.scene: dict | None = None
        self.scene_hash = ""
        self._scene_frames: dict[str, bytes | str] = {}
        self.health_frames: dict[str, bytes | str] = {}
        self._lease_frames: dict[str, bytes | str] = {}
        self.event_log = EventLog()  # the state frames' events, numbered (server/hub/event_log.py)
        self._state: dict | None = None  # the latest state message
        self._frames_events = 0  # the number of the latest state message's last event
        self._broadcast_events = 0  # the number of the last event a broadcast carried
        self._frame_seq = 0
        self.ceiling = FrameCeiling(server.state_hz, time.monotonic_ns())
        self._broadcaster: asyncio.Task | None = None
        if access is not None:  # its lease changes (from any thread: REST runs lease calls on workers)
            access.on_lease_change = self._lease_changed_anywhere
            self.set_lease(access.lease.snapshot())

    # ---- what every client is sent ---------------------------------------------------------------
    def publish_state(self, message: dict) -> None:
        """The loop's latest state message, offered to every welcomed client by the broadcaster, at
        most as often as the frame ceiling lets (server/hub/frame_ceiling.py): one that comes
        sooner waits, and a newer one replaces it (its events go with the newer)."""
        self._state = message
        self._frames_events = self.event_log.add(message["events"])  # a client that misses it still gets these
        self._frame_seq += 1
        if self._broadcaster is None or self._broadcaster.done():
            self._broadcaster = asyncio.get_running_loop().create_task(self._broadcast())

    async def _broadcast(self) -> None:
        delivered = 0
        while delivered != self._frame_seq:
            wait_ns = self.ceiling.wait_ns(time.monotonic_ns())
            if wait_ns:
                await asyncio.sleep(wait_ns / 1e9)
                continue
            self.ceiling.spend(time.monotonic_ns())
            delivered = self._frame_seq
            message, frames, upto = self._latest_frames()
            scene = message["scene"]  # the scene the frame names, known without decoding it
            # Participants and operators first: the frame showing their own hand must not wait behind
            # every viewer's send (docs/performance.md, "Tracker → state round trip (/ws)").
            for i, c in enumerate(sorted(self.connections.values(), key=lambda c: c.session.role == "observer")):
                frame = frames.get(c.session.fmt)
                if not c.session.welcomed or frame is None:
                    continue
                c.session.offer_state(frame, scene, message, upto)
                c.wake.set()
                if (i + 1) % SLICE == 0:
                    await asyncio.sleep(0)  # let tracker reads in between slices

    def _latest_frames(self) -> tuple[dict, dict[str, bytes | str], int]:
        """The latest state message with the events of every message the ceiling held back since the
        last broadcast in front of its own, encoded once per format in use, and its last event's
        number. The message returned lists those events uncapped (Outbox counts from them); the
        frames carry at most MAX_WIRE_EVENTS."""
        message, upto = self._state, self._frames_events
        own = message["events"]
        held_back = self.event_log.between(self._broadcast_events, upto - len(own))
        self._broadcast_events = upto
        wire = message
        if held_back:
            message = {**message, "events": [*held_back, *own]}
            wire = {**message, "events": messages.wire_events(message["events"])}
        formats = {c.session.fmt for c in self.connections.values() if c.session.welcomed}
        return message, {fmt: codec.encode(wire, fmt) for fmt in formats}, upto

    def set_scene(self, scene: dict, scene_hash: str) -> None:
        self.scene, self.scene_hash = scene, scene_hash
        message = messages.scene_message(scene, scene_hash)
        self._scene_frames = {fmt: codec.encode(message, fmt) for fmt in codec.FORMATS}
        for c in self.connections.values():
            c.session.set_scene(scene_hash, self._scene_frames)
            c.wake.set()

    def set_health(self, message: dict) -> None:
        self.health_frames = {fmt: codec.encode(message, fmt) for fmt in codec.FORMATS}
        for c in self.connections.values():
            c.session.set_health(self.health_frames)
            c.wake.set()

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
            self.forward(c, c.session.set_lease(self._lease_frames))
            c.wake.set()

    def clients(self) -> list[dict]:
        return [c.session.info() for c in self.connections.values()]

    # ---- access control (server/auth) ------------------------------------------------------------
    def _gate(self, ws: WebSocket) -> Gate:
        access = self.access
        if access is None:
            return CLOSED
        client = ws.scope.get("client")
        peer = client[0] if client else "unknown"
        return gate_of(access, peer, self._admit)

    def _admit(self, who) -> str | None:
        n = sum(1 for c in self.connections.values()
                if c.session.identity is not None and c.session.identity.token_id == who.token_id)
        if n >= MAX_CONNECTIONS_PER_TOKEN:
            return f"token {who.token_id} already has {n} connections open (at most {MAX_CONNECTIONS_PER_TOKEN})"
        return None

    # ---- one WebSocket connection -----------------------------------------------------
    async def serve(self, ws: WebSocket) -> None:
        self.owner.check()
        offered = ws.scope.get("subprotocols") or []
        chosen = next((p for p in offered if p in codec.SUBPROTOCOLS), None)
        await ws.accept(subprotocol=chosen)
        session = Session(next(self._ids), codec.SUBPROTOCOLS.get(chosen, "msgpack"), self.server, time.monotonic_ns(),
                          gate=self._gate(ws), events=self.event_log)
        if self._scene_frames:
            session.set_scene(self.scene_hash, self._scene_frames)
        if self.health_frames:
            session.set_health(self.health_frames)
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
                self.forward(c, session.receive(data, time.monotonic_ns()))
                if not welcomed and session.welcomed:
                    self.on_welcomed(c)
                c.wake.set()
                # One message, then the other tasks: one read of the socket holds up to ~1,000 small
                # messages, which `receive` hands over without yielding, and a flooder would keep the
                # viewers' senders, the broadcaster and REST (/api/health) waiting for all of them.
                await asyncio.sleep(0)
            # We are closing (e.g. unsupported version): let the sender flush the error first.
            await asyncio.wait_for(asyncio.shield(sender), FLUSH_BEFORE_CLOSE_S)
        except (WebSocketDisconnect, RuntimeError, asyncio.TimeoutError):
            pass
        finally:
            self.connections.pop(session.id, None)
            sender.cancel()
            self.forward(c, session.disconnected())

    async def _sender(self, c: Connection) -> None:
        try:
            while True:
                await c.wake.wait()
                c.wake.clear()
                while (item := c.session.outbox.next_frame()) is not None:
                    if isinstance(item, Close):
                        await (c.ws.close(code=item.code, reason=item.reason) if item.reason else c.ws.close(code=item.code))
                        return
                    if isinstance(item, bytes):
                        await c.ws.send_bytes(item)
                    else:
                        await c.ws.send_text(item)
        except (WebSocketDisconnect, RuntimeError, OSError):
            return
