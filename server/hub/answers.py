"""The answer broker: a participant's study answers (protocol v1.5 `answer`) go to `on_answer` on
a worker thread (the engine writes SQLite), and its refusal back to the client; what a session's
participant is asked (`publish_ask`, from the engine's changes) reaches that session's participant
connections, and a participant that connects later gets the latest (`participant_view`, read on
a worker thread)."""

from __future__ import annotations

import asyncio
import logging
from typing import Callable

from server.hub.fanout import Connection
from server.hub.owner import Owner
from server.hub.session import ParticipantAnswer
from server.wire import codec, messages

log = logging.getLogger("viestac.hub")


def _no_study(answer: ParticipantAnswer) -> tuple[str, str]:
    return "conflict", "this server records no study answers"


class AnswerBroker:
    """`connections`: the fan-out's, by client id (read, never changed here)."""

    def __init__(self, owner: Owner, connections: dict[int, Connection]):
        self.owner = owner
        self.connections = connections
        # participants' answers (the experiment engine; worker thread): None when recorded, else
        # (error code, message) for the client
        self.on_answer: Callable[[ParticipantAnswer], tuple[str, str] | None] = _no_study
        self.participant_view: Callable[[str], dict | None] = lambda session_id: None  # a session's `ask` view
        self._asks: dict[str, dict[str, bytes | str]] = {}  # session → its latest `ask` per format
        self._tasks: set[asyncio.Task] = set()  # answers and reads under way (held: a bare task may be collected)

    def connect(self, on_answer: Callable[[ParticipantAnswer], tuple[str, str] | None],
                participant_view: Callable[[str], dict | None]) -> None:
        """The study behind the answers (the app wires the experiment's, server/api/participant_answers.py)."""
        self.on_answer, self.participant_view = on_answer, participant_view

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

    def offer_ask(self, c: Connection) -> None:
        """A client was welcomed: a participant of a session gets its latest `ask`, read first if need be."""
        session_id = c.session.asks_for
        if session_id is None:
            return
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

    def answer(self, c: Connection, answer: ParticipantAnswer) -> None:
        """Record a participant's answer off the event loop; a refusal goes back to its client."""
        self._spawn(self._answer(c, answer))

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
