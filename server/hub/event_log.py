"""The scenario events the hub has put into state frames, numbered in order.

A client is sent the newest state frame only: the hub offers each client the latest frame, and a
frame still waiting in a client's slot is replaced by the next (server/hub/session.py). The
picture may skip a frame; its events may not, or a slow viewer's event line, the console's log
and a headset's audio cue would miss a tap or a trial's end. With each frame the hub notes the
number of its last event here, and a client whose next frame does not follow on from the last
one it was sent gets the events in between put in front of that frame's own.
"""

from __future__ import annotations

from collections import deque

MAX_KEPT = 1000  # events kept for clients that fell behind; one further behind gets the newest of them


class EventLog:
    def __init__(self, kept: int = MAX_KEPT):
        self._events: deque[tuple[int, dict]] = deque(maxlen=kept)  # (number, event), oldest first
        self.last = 0  # the number of the newest event; 0: none yet

    def add(self, events) -> int:
        """Number a frame's events, in order; returns the number of the last one (the frame's mark)."""
        for event in events:
            self.last += 1
            self._events.append((self.last, event))
        return self.last

    def between(self, after: int, upto: int) -> list[dict]:
        """The events numbered after `after` up to `upto` that are still kept, oldest first."""
        if upto <= after:
            return []
        return [event for number, event in self._events if after < number <= upto]
