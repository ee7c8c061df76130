"""Participants' study answers over /ws (protocol v1.5 `answer`, `ask`): the glue between the
hub and the experiment engine. The hub calls `answer` and `view` on a worker thread (the engine
writes SQLite); the engine calls `changed` after every change a participant's page shows, and the
new view goes to the hub on its own thread.

An answer is recorded by the same engine check as the console's
`PUT /api/sessions/{id}/trials/{seq}/responses/{question}` and audited like it (action
`ws:answer`, target that route's path, the session's site)."""

from __future__ import annotations

import logging

from server.experiment.engine import Experiment, ExperimentError, Forbidden, NotFound
from server.experiment.pacing import CONTINUE_QUESTION
from server.experiment.store import Conflict, StoreError
from server.hub.session import ParticipantAnswer

log = logging.getLogger("viestac.answers")


class ParticipantAnswers:
    def __init__(self, experiment: Experiment, hub, audit=None):
        self.experiment = experiment
        self.hub = hub
        self.audit = audit  # server.auth.audit.Audit, or None (tests)
        self.pacing = None  # server/api/paced_sessions.py PacedSessions: `ask.pacing`, and a break's "continue"

    def answer(self, a: ParticipantAnswer) -> tuple[str, str] | None:
        """Record one answer: None, or (error code, message) for the participant's page."""
        try:
            if a.question == CONTINUE_QUESTION:  # not a study question: the participant ends a break
                refusal = self._continue(a)
            else:
                self.experiment.participant_answer(a.session_id, a.seq, a.question, a.value)
                refusal = None
        except Forbidden as exc:
            refusal = ("forbidden", str(exc))
        except (NotFound, Conflict, StoreError) as exc:
            refusal = ("conflict", str(exc))
        except ExperimentError as exc:  # the value does not fit the question
            refusal = ("bad_message", str(exc))
        self._audit(a, refusal)
        return refusal

    def _continue(self, a: ParticipantAnswer) -> tuple[str, str] | None:
        if self.pacing is None or not self.pacing.continue_break(a.session_id):
            return "conflict", "no break to continue from: the session is not on a participant-paced break"
        return None

    def _audit(self, a: ParticipantAnswer, refusal: tuple[str, str] | None) -> None:
        if self.audit is None:
            return
        result = "ok" if refusal is None else f"refused {refusal[0]}"
        try:
            site = self.experiment.site_of(a.session_id)
        except ExperimentError:
            site = None
        self.audit.record(a.identity, "ws:answer", f"/api/sessions/{a.session_id}/trials/{a.seq}/responses/{a.question}",
                          result, session_id=a.session_id, site=site)

    def view(self, session_id: str) -> dict | None:
        try:
            view = self.experiment.participant_view(session_id)
        except NotFound:
            return None
        return {**view, "pacing": None if self.pacing is None else self.pacing.view(session_id)}

    def changed(self, session_id: str) -> None:
        """The engine changed `session_id` (any thread but the hub's): its participants' new view."""
        owner = self.hub.owner
        if owner.loop is None:  # not serving (a test without a hub loop)
            return
        view = self.view(session_id)
        if owner.here:
            self.hub.publish_ask(session_id, view)
        else:
            owner.loop.call_soon_threadsafe(self.hub.publish_ask, session_id, view)
