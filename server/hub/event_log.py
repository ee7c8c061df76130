"""The scenario events the hub has put into state frames, numbered in order.

A client is sent the newest state frame only: the hub offers each client the latest frame, and a
frame still waiting in a client's slot is replaced by the next (server/hub/session.py). The
picture may skip a frame; its events may not, or a slow viewer's event line, the console's log
and a headset's audio cue would miss a tap or a trial's end. With each frame the hub notes the
number of its last event here, and a client whose next frame does not follow on from the last
one it was sent gets the events in between put in front of that frame's own.

Each `input` event (a key or command, with the `client` that sent it) is stamped with who caused
it, `by: {token_id, site}`, from the actors the hub names (`name_actor`: each welcomed /ws
connection, and client 0 for the lease holder's REST commands): the state frames and the
recorder's event rows (docs/data.md) then say which token of which lab changed the rig.
"""

from __future__ import annotations

from collections import deque

MAX_KEPT = 1000  # events kept for clients that fell behind; one further behind gets the newest of them
MAX_ACTORS = 4096  # clients remembered for stamping (a departed client's last input may still come)


class EventLog:
    def __init__(self, kept: int = MAX_KEPT):
        self._events: deque[tuple[int, dict]] = deque(maxlen=kept)  # (number, event), oldest first
        self.last = 0  # the number of the newest event; 0: none yet
        self._actors: dict[int, dict] = {}  # client id -> {"token_id", "site"}, oldest first

    def name_actor(self, client_id: int, identity) -> None:
        """`client_id`'s inputs come from this identity (server.auth.Identity; None: forget it)."""
        self._actors.pop(client_id, None)
        if identity is not None:
            self._actors[client_id] = {"token_id": identity.token_id, "site": identity.site}
            while len(self._actors) > MAX_ACTORS:
                del self._actors[next(iter(self._actors))]

    def add(self, events) -> int:
        """Number a frame's events, in order, stamping who caused each `input` event; returns the
        number of the last one (the frame's mark)."""
        for event in events:
            if event.get("name") == "input" and "by" not in event and event.get("client") in self._actors:
                event["by"] = self._actors[event["client"]]
            self.last += 1
            self._events.append((self.last, event))
        return self.last

    def between(self, after: int, upto: int) -> list[dict]:
        """The events numbered after `after` up to `upto` that are still kept, oldest first."""
        if upto <= after:
            return []
        return [event for number, event in self._events if after < number <= upto]
