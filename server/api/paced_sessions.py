"""The pacer's asyncio shell (docs/studies.md "Participant-paced tasks"): for every session with a
participant-paced task, it feeds the sans-I/O pacer (server/experiment/pacing.py) the session's
queue after each change and at the times it asks for, and carries out what it decides through the
engine, as the console that holds the session's control token would (no token, no pacing).

It lives on the hub's event loop and never blocks it: the engine's calls (SQLite) run on the
thread pool the REST handlers use (`asyncio.to_thread`). The engine's `on_change` comes from any
thread; each session's steps run one after another (a change during a step runs another step).
The participant's page learns the pacer's state in `ask.pacing` (`view`, read from any thread)."""

from __future__ import annotations

import asyncio
import logging
import time
from typing import Callable

from server.core.scenario import ParamError
from scenarios.registry import UnknownScenario
from server.experiment.engine import Experiment, ExperimentError
from server.experiment.pacing import Decision, Pacer, QueuedTrial
from server.experiment.store import StoreError
from server.hub.control import BusyError, ScenarioRefused
from server.hub.owner import Owner

log = logging.getLogger("viestac.pacing")

REFUSALS = (ExperimentError, StoreError, ParamError, UnknownScenario, ScenarioRefused, BusyError)


def _monotonic_ms() -> float:
    return time.monotonic() * 1000.0


class PacedSessions:
    """`publish(session_id)`: send the session's participants their new `ask` (it reads the view
    itself; called on a worker thread)."""

    def __init__(self, experiment: Experiment, owner: Owner, publish: Callable[[str], None],
                 clock: Callable[[], float] = _monotonic_ms):
        self.experiment = experiment
        self.owner = owner
        self.publish = publish
        self.clock = clock
        self._pacers: dict[str, Pacer] = {}
        self._views: dict[str, dict | None] = {}    # session → its `ask.pacing` (replaced whole: read off the loop)
        self._timers: dict[str, asyncio.TimerHandle] = {}
        self._dirty: set[str] = set()
        self._stale: set[str] = set()               # the engine changed it since its `ask` was last published
        self._tasks: dict[str, asyncio.Task] = {}   # one stepper per session at a time

    # -- from other threads ------------------------------------------------------------------
    def view(self, session_id: str) -> dict | None:
        """The session's `ask.pacing` (None: the task at hand is not participant-paced)."""
        return self._views.get(session_id)

    def paces(self, session_id: str) -> bool:
        """This shell publishes the session's `ask` after each change (with the pacing that follows it)."""
        return session_id in self._pacers

    def changed(self, session_id: str) -> None:
        """The engine changed the session (any thread)."""
        loop = self.owner.loop
        if loop is None:  # not serving (a test without a hub loop)
            return
        if self.owner.here:
            self._engine_changed(session_id)
        else:
            loop.call_soon_threadsafe(self._engine_changed, session_id)

    def look(self, session_id: str) -> None:
        """Look at a session not seen since the server started (any thread): a console reads it."""
        loop = self.owner.loop
        if loop is not None:
            loop.call_soon_threadsafe(self.poke, session_id)

    def _engine_changed(self, session_id: str) -> None:
        self._stale.add(session_id)
        self.poke(session_id)

    def continue_break(self, session_id: str) -> bool:
        """The participant ends its break (any thread): False when no break is held."""
        return self.owner.call(self._continue_break, session_id)

    # -- on the event loop -------------------------------------------------------------------
    def poke(self, session_id: str) -> None:
        """Look at the session again (soon, on the event loop)."""
        self.owner.check()
        self._dirty.add(session_id)
        if session_id not in self._tasks:
            task = asyncio.get_running_loop().create_task(self._run(session_id))
            self._tasks[session_id] = task

    def pause(self, session_id: str) -> None:
        """The experimenter pauses: nothing new starts (a running trial may still be answered)."""
        self._pacer(session_id).pause()
        self.poke(session_id)

    def resume(self, session_id: str) -> None:
        """The experimenter goes on (also after a restart, or to start a paced task's next trial)."""
        self._pacer(session_id).resume(self.clock())
        self.poke(session_id)

    def _pacer(self, session_id: str) -> Pacer:
        """The session's pacer (a new one learns its tasks' pacing at its first step)."""
        self.owner.check()
        pacer = self._pacers.get(session_id)
        if pacer is None:
            pacer = self._pacers[session_id] = Pacer({})
        return pacer

    def _continue_break(self, session_id: str) -> bool:
        pacer = self._pacers.get(session_id)
        if pacer is None or not pacer.continue_break(self.clock()):
            return False
        self.poke(session_id)
        return True

    async def _run(self, session_id: str) -> None:
        try:
            while session_id in self._dirty:
                self._dirty.discard(session_id)
                try:
                    await self._step(session_id)
                except Exception:  # a failed step must not end the pacing; the next change tries again
                    log.exception("pacing session %s failed", session_id)
        finally:
            self._tasks.pop(session_id, None)

    async def _step(self, session_id: str) -> None:
        session = await asyncio.to_thread(self.experiment.session, session_id)
        study = await asyncio.to_thread(self.experiment.study, session["study_id"])
        pacing = {t.id: t.pacing for t in study.tasks if t.pacing.paced}
        if not pacing:  # nothing of this session is paced: its `ask` as ever
            await self._show(session_id, None)
            self._forget(session_id)
            return
        pacer = self._pacer(session_id)
        pacer.pacing = pacing  # as the study file says now
        trials = [QueuedTrial.from_session(t, self._required(study, t)) for t in session["trials"]]
        now = self.clock()
        token = self.experiment.control_token(session_id)
        pacer.controlled = token is not None
        pacer.observe(now, trials)
        decision = pacer.decide(now)
        if decision.action in ("start", "finish"):
            await self._act(session_id, pacer, decision, token)  # its change pokes this session again
            return
        wakes = [decision.at_ms] if decision.action == "wait" else []
        if (at := pacer.next_change_ms(now)) is not None:  # the feedback ends: a new view
            wakes.append(at)
        if wakes:
            self._wake(session_id, min(wakes))
        await self._show(session_id, pacer.view(self.clock()))

    async def _show(self, session_id: str, view: dict | None) -> None:
        """The participant's new `ask`, when the engine changed the session or the pacing changed."""
        stale = session_id in self._stale
        self._stale.discard(session_id)
        if not stale and self._views.get(session_id) == view:
            return
        self._views[session_id] = view
        await asyncio.to_thread(self.publish, session_id)

    @staticmethod
    def _required(study, trial: dict) -> list[str]:
        try:
            task = study.task(trial["task"])
            return [q for q in trial.get("questions") or () if task.question(q).required]
        except KeyError:  # the file changed under the session: nothing to wait for
            return []

    async def _act(self, session_id: str, pacer: Pacer, decision: Decision, token: str) -> None:
        try:
            if decision.action == "finish":
                await asyncio.to_thread(self.experiment.finish, session_id, token, decision.seq)
            else:
                await asyncio.to_thread(self.experiment.start, session_id, token, decision.seq)
                log.info("pacing: session %s trial %d started", session_id, decision.seq)
        except REFUSALS as exc:
            log.warning("pacing: session %s could not %s trial %s: %s", session_id, decision.action, decision.seq, exc)
            if decision.action == "start":  # a missing device, another session's trial: the experimenter decides
                pacer.refused(f"trial {decision.seq} could not start: {exc}")
            self.poke(session_id)

    def _wake(self, session_id: str, at_ms: float) -> None:
        old = self._timers.pop(session_id, None)
        if old is not None:
            old.cancel()
        delay_s = max(0.0, (at_ms - self.clock()) / 1000.0)
        self._timers[session_id] = asyncio.get_running_loop().call_later(delay_s, self.poke, session_id)

    def _forget(self, session_id: str) -> None:
        self._pacers.pop(session_id, None)
        self._views.pop(session_id, None)
        timer = self._timers.pop(session_id, None)
        if timer is not None:
            timer.cancel()

    def console_view(self, session_id: str) -> dict | None:
        """What the console shows: the participant's view with the pacer's own note (why it paused)."""
        view = self._views.get(session_id)
        pacer = self._pacers.get(session_id)
        if view is None or pacer is None:
            return view
        return {**view, "note": pacer.note}
