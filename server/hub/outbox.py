"""What one /ws client is sent, in order (I/O-free; the session fills it, the hub's sender takes
from it with `next_frame()`): an ordered control queue (welcome, scene, health, lease, ask,
errors, a close) and a latest-wins slot for state frames. A frame that was replaced in the slot
(or never offered: the hub offers the newest) loses its picture, not its events: the next frame
sent carries them first (server/hub/event_log.py). A state frame whose scene is not the last
scene handed out is dropped when it is taken (the slot may hold a frame of the previous scene
when the new scene goes first: control is sent before the slot)."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any, Mapping

from server.hub.event_log import EventLog
from server.wire import codec, messages

MAX_PENDING_ERRORS = 64  # a client that floods bad frames and does not read gets no more replies queued


@dataclass(frozen=True)
class Close:
    """Close the connection with this code (after everything queued before it) and reason (the close
    frame's text: "revoked", "expired"; docs/security.md)."""
    code: int
    reason: str = ""


class Outbox:
    def __init__(self, fmt: str, events: EventLog | None = None):
        self.fmt = fmt
        # control items: (kind, frame, scene hash or None) with kind welcome | scene | health | lease | ask |
        # error, or a Close; the slot: (frame, scene hash, its message, the number of its last event)
        self._control: deque = deque()
        self._slot: tuple | None = None
        self.events = events  # the hub's numbered events (None: a frame's events are its own only)
        self._events_through: int | None = None  # the last event number in a frame sent to this client
        self._pending_errors = 0
        self._sent_scene: str | None = None  # the last scene handed to the sender
        self._closed = False  # Close was handed out: nothing more goes
        # counters (GET /api/clients)
        self.frames_sent = 0
        self.frames_dropped = 0
        self.events_carried = 0  # events of frames this client missed, sent with a later frame

    def put(self, kind: str, frame: bytes | str, scene_hash: str | None = None) -> None:
        self._control.append((kind, frame, scene_hash))

    def latest(self, kind: str, frame: bytes | str, scene_hash: str | None = None) -> None:
        """Queue `frame`, superseding one of its kind still waiting (only the latest is true)."""
        if any(_is_kind(item, kind) for item in self._control):
            self._control = deque(item for item in self._control if not _is_kind(item, kind))
        self._control.append((kind, frame, scene_hash))

    def error(self, code: str, text: str) -> None:
        """One `error` frame, unless MAX_PENDING_ERRORS are waiting already."""
        if self._pending_errors >= MAX_PENDING_ERRORS:
            return
        self._pending_errors += 1
        self._control.append(("error", codec.encode(messages.error(code, text), self.fmt), None))

    def close(self, code: int, reason: str = "") -> None:
        self._control.append(Close(code, reason))

    def offer_state(self, frame: bytes | str, scene_hash: str, message: Mapping[str, Any] | None,
                    events_upto: int | None) -> None:
        """The latest state frame; it replaces a frame not yet sent (counted as dropped)."""
        if self._slot is not None:
            self.frames_dropped += 1
        self._slot = (frame, scene_hash, message, events_upto)

    @property
    def pending(self) -> bool:
        """Something is waiting for the sender."""
        return not self._closed and (bool(self._control) or self._slot is not None)

    def next_frame(self) -> bytes | str | Close | None:
        """What the sender sends next: control messages in order, then the latest state frame;
        None when nothing is waiting. After a `Close`, nothing."""
        if self._closed:
            return None
        while self._control:
            item = self._control.popleft()
            if isinstance(item, Close):
                self._closed = True
                return item
            kind, frame, scene_hash = item
            if kind == "error":
                self._pending_errors -= 1
            elif kind == "scene":
                self._sent_scene = scene_hash
            return frame
        if self._slot is None:
            return None
        (frame, scene_hash, message, upto), self._slot = self._slot, None
        if scene_hash != self._sent_scene:  # of a scene this client was not (or no longer) sent
            self.frames_dropped += 1  # (its events go with the next frame sent)
            return None
        if upto is not None and self.events is not None:
            frame = self._with_missed_events(frame, message, upto)
        self.frames_sent += 1
        return frame

    def _with_missed_events(self, frame: bytes | str, message: Mapping[str, Any], upto: int) -> bytes | str:
        """`frame`, or, when this client was not sent the frames just before it, the frame encoded
        again with their events in front of its own (each event once, in order)."""
        own = message["events"]
        through, self._events_through = self._events_through, upto
        if through is None:  # the first frame: events from here on
            return frame
        missed = self.events.between(through, upto - len(own))
        if not missed:
            return frame
        self.events_carried += len(missed)
        return codec.encode({**message, "events": messages.wire_events([*missed, *own])}, self.fmt)


def _is_kind(item, kind: str) -> bool:
    return isinstance(item, tuple) and item[0] == kind
