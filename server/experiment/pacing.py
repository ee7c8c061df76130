"""Participant-paced tasks (a study's `[tasks.pacing]`, docs/studies.md "Participant-paced tasks"):
the pacer decides, for one session, what happens next without the console. Pure: no clock, no
engine, no threads; the shell (server/api/paced_sessions.py) feeds it the session's queue and the
time and carries out what it says.

Rules (Contract C5):
- A trial of a paced task is finished as soon as every required question of it has its answer.
- The next pending trial starts `iti_ms` after the previous one of the same task ended (or after
  the feedback, when that is longer), but only when the pacer itself saw that trial end, or the
  experimenter resumed: a task's first trial, a trial after an abort and the first trial after a
  server restart wait for the experimenter (the console's Start, or Resume).
- Feedback ("correct" / "wrong") shows for `feedback_ms` after a trial whose metrics carry
  `psy.correct` (Contract C3), when the file asks for it; without it there is no feedback.
- Every `break_every` ended trials of the task (not after its last) the pacer holds a break until
  the participant continues.
- The experimenter may pause at any time (a running trial may still be answered and finished;
  nothing new starts) and resume. Only trial-phase and main trials are paced; the task's end
  (its questionnaire, the next task) waits for the experimenter.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Sequence

PACED_BY = ("experimenter", "participant")
PACED_KINDS = ("trial", "main")  # training is timed exploration, a questionnaire the task's end
ENDED = ("answered", "aborted", "excluded")
CONTINUE_QUESTION = "pacing:continue"  # the `answer` that ends a break (never a study question id: it has a colon)

# What the participant's page is told (protocol `ask.pacing.state`).
STATES = ("trial", "next", "feedback", "break", "paused", "experimenter")


@dataclass(frozen=True)
class Pacing:
    """A task's `[tasks.pacing]` table (the defaults are the file's)."""
    by: str = "experimenter"   # "participant": the pacer runs the task's trials
    iti_ms: int = 800          # a trial's end → the next trial's start
    feedback: bool = False     # show "correct"/"wrong" (metrics.psy.correct) after each answer
    feedback_ms: int = 600
    break_every: int = 0       # a break after every N ended trials; 0: none

    @property
    def paced(self) -> bool:
        return self.by == "participant"

    def to_dict(self) -> dict:
        return {"by": self.by, "iti_ms": self.iti_ms, "feedback": self.feedback, "feedback_ms": self.feedback_ms,
                "break_every": self.break_every}


EXPERIMENTER_PACED = Pacing()


@dataclass(frozen=True)
class QueuedTrial:
    """What the pacer reads of one trial of the session's queue."""
    seq: int
    task: str
    kind: str
    status: str
    answered: bool = False        # every required question has its answer
    correct: bool | None = None   # metrics.psy.correct of an ended trial (None: no such metric)

    @classmethod
    def from_session(cls, trial: Mapping[str, Any], required: Sequence[str]) -> QueuedTrial:
        """From a trial of the engine's session view; `required`: its required question ids."""
        responses = trial.get("responses") or {}
        psy = (trial.get("metrics") or {}).get("psy")
        correct = psy.get("correct") if isinstance(psy, Mapping) else None
        return cls(seq=trial["seq"], task=trial["task"], kind=trial["kind"], status=trial["status"],
                   answered=bool(required) and all(responses.get(q) is not None for q in required),
                   correct=correct if isinstance(correct, bool) else None)


@dataclass(frozen=True)
class Decision:
    """What to do now: `finish` or `start` trial `seq`, `wait` until `at_ms` (then ask again), or
    `idle` (nothing until the next event)."""
    action: str
    seq: int | None = None
    at_ms: float | None = None


IDLE = Decision("idle")


@dataclass(frozen=True)
class _Ended:
    seq: int
    task: str
    at_ms: float
    correct: bool | None


class Pacer:
    """One session's pacing. `pacing`: every task's Pacing by task id (a task not named is
    experimenter-paced)."""

    def __init__(self, pacing: Mapping[str, Pacing]):
        self.pacing = dict(pacing)
        self.trials: tuple[QueuedTrial, ...] = ()
        self.paused = False
        self.controlled = True              # a console holds the session's control token (else nothing moves)
        self.note = ""                      # why the pacer paused by itself (a refused start), for the console
        self._ended: _Ended | None = None   # the last trial the pacer saw end
        self._armed_at: float | None = None  # resumed or continued: the next start counts from here
        self._running: int | None = None
        self._continued = 0                  # the ended count whose break the participant ended

    # -- events ------------------------------------------------------------------------------
    def observe(self, now_ms: float, trials: Sequence[QueuedTrial]) -> None:
        """The session's queue after a change (any change: a start, an answer, an end)."""
        self.trials = tuple(trials)
        running = self._find_running()
        if self._running is not None and (running is None or running.seq != self._running):
            before = self._by_seq(self._running)
            if before is not None and before.status in ENDED:
                self._ended = _Ended(before.seq, before.task, now_ms, before.correct)
                self._armed_at = None
                if before.status == "aborted":  # the experimenter stepped in: nothing follows by itself
                    self.paused = True
        self._running = running.seq if running is not None else None

    def pause(self) -> None:
        self.paused = True

    def resume(self, now_ms: float) -> None:
        """The experimenter goes on: the next trial of a paced task starts after its inter-trial interval
        (a break held now ends with it)."""
        self.paused = False
        self.note = ""
        self._armed_at = now_ms
        nxt = self._next()
        if nxt is not None:
            self._continued = self._ended_in_task(nxt.task)

    def refused(self, why: str) -> None:
        """A start the engine refused (a missing device, another session's trial): hold until resumed."""
        self.paused = True
        self.note = why

    def continue_break(self, now_ms: float) -> bool:
        """The participant ends the break (False: no break is held now)."""
        if self.state(now_ms) != "break":
            return False
        self._continued = self._ended_in_task(self._next().task)
        self._armed_at = now_ms
        return True

    # -- decisions ---------------------------------------------------------------------------
    def decide(self, now_ms: float) -> Decision:
        if not self.controlled:
            return IDLE
        running = self._find_running()
        if running is not None:
            if self._paces(running) and running.answered:
                return Decision("finish", running.seq)
            return IDLE
        nxt = self._next()
        if nxt is None or not self._paces(nxt) or self.paused or not self._armed(nxt):
            return IDLE
        pacing = self.pacing[nxt.task]
        if self._break_due(nxt):
            return IDLE
        start_at = self._start_at(pacing)
        if now_ms < start_at:
            return Decision("wait", at_ms=start_at)
        return Decision("start", nxt.seq)

    def state(self, now_ms: float) -> str | None:
        """What the participant's page shows (STATES), or None when the task at hand is not paced."""
        running = self._find_running()
        current = running or self._next()
        if current is None or not self._paces(current):
            return None
        if running is not None:
            return "trial"
        if self.paused:
            return "paused"
        if not self.controlled or not self._armed(current):
            return "experimenter"
        if self._feedback_shown(now_ms) is not None:
            return "feedback"
        if self._break_due(current):
            return "break"
        return "next"

    def view(self, now_ms: float) -> dict | None:
        """The `ask.pacing` map: {state, done, total, feedback}; None when the task at hand is not paced."""
        state = self.state(now_ms)
        if state is None:
            return None
        current = self._find_running() or self._next()
        feedback = self._feedback_shown(now_ms)
        return {"state": state, "done": self._ended_in_task(current.task),
                "total": sum(1 for t in self.trials if t.task == current.task and t.kind in PACED_KINDS),
                "feedback": None if feedback is None else ("correct" if feedback else "wrong")}

    def next_change_ms(self, now_ms: float) -> float | None:
        """When the view changes by itself (the feedback ends), if it will."""
        if self._feedback_shown(now_ms) is None:
            return None
        return self._ended.at_ms + self.pacing[self._ended.task].feedback_ms

    # -- helpers -----------------------------------------------------------------------------
    def _by_seq(self, seq: int) -> QueuedTrial | None:
        return next((t for t in self.trials if t.seq == seq), None)

    def _find_running(self) -> QueuedTrial | None:
        return next((t for t in self.trials if t.status == "running"), None)

    def _next(self) -> QueuedTrial | None:
        return next((t for t in self.trials if t.status == "pending"), None)

    def _paces(self, trial: QueuedTrial) -> bool:
        pacing = self.pacing.get(trial.task)
        return pacing is not None and pacing.paced and trial.kind in PACED_KINDS

    def _armed(self, nxt: QueuedTrial) -> bool:
        """The pacer may start `nxt`: it saw the task's previous trial end, or the experimenter resumed."""
        return self._armed_at is not None or (self._ended is not None and self._ended.task == nxt.task)

    def _ended_in_task(self, task: str) -> int:
        return sum(1 for t in self.trials if t.task == task and t.kind in PACED_KINDS and t.status in ENDED)

    def _break_due(self, nxt: QueuedTrial) -> bool:
        every = self.pacing[nxt.task].break_every
        done = self._ended_in_task(nxt.task)
        return every > 0 and done > 0 and done % every == 0 and self._continued != done

    def _feedback_shown(self, now_ms: float) -> bool | None:
        """The feedback on the page now (True: correct), or None."""
        e = self._ended
        if e is None or e.correct is None or self._running is not None:
            return None
        pacing = self.pacing.get(e.task)
        if pacing is None or not pacing.paced or not pacing.feedback or now_ms >= e.at_ms + pacing.feedback_ms:
            return None
        return e.correct

    def _start_at(self, pacing: Pacing) -> float:
        if self._armed_at is not None:
            return self._armed_at + pacing.iti_ms
        e = self._ended
        shown = pacing.feedback_ms if pacing.feedback and e.correct is not None else 0
        return e.at_ms + max(pacing.iti_ms, shown)
