"""The pacer's asyncio shell (server/api/paced_sessions.py) against an engine stand-in whose finished
trials carry `metrics.psy.correct` (Contract C3, which the psychophysics engine writes): the page is
told "correct" / "wrong" for `feedback_ms`, then the next trial starts; the engine's calls run off
the event loop; a refused start pauses the pacer with its reason; no control token, no pacing."""

from __future__ import annotations

import asyncio
import threading

from server.api.paced_sessions import PacedSessions
from server.experiment.store import Conflict
from server.experiment.study import parse_study
from server.hub.owner import Owner

STUDY = parse_study("""
id = "fb"
title = "Feedback"
seed = 1
participants = 1

[[tasks]]
id = "detect"
scenario = "contact-angle"
conditions = [{ angle_deg = 10 }, { angle_deg = 20 }, { angle_deg = 30 }]
order = "fixed"

[tasks.pacing]
by = "participant"
iti_ms = 50
feedback = true
feedback_ms = 250

[[tasks.questions]]
id = "response"
kind = "choice"
text = "Which?"
choices = ["1", "2"]
answered_by = "participant"
""", "fb.toml")


class Engine:
    """The engine's calls the shell makes; the right answer is always "2" (as a procedure's target)."""

    def __init__(self, token: str | None = "tok", refuse_start: str | None = None):
        self.token = token
        self.refuse_start = refuse_start
        self.trials = [{"seq": i, "task": "detect", "kind": "main", "status": "pending", "questions": ["response"],
                        "responses": {}, "metrics": {}} for i in range(3)]
        self.on_change = lambda sid: None
        self.threads: set[int] = set()
        self.calls: list[tuple] = []

    def session(self, sid):
        self.threads.add(threading.get_ident())
        return {"id": sid, "study_id": "fb", "trials": [dict(t) for t in self.trials]}

    def study(self, study_id):
        return STUDY

    def control_token(self, sid):
        return self.token

    def start(self, sid, token, seq):
        self.threads.add(threading.get_ident())
        self.calls.append(("start", seq))
        if self.refuse_start:
            raise Conflict(self.refuse_start)
        self.trials[seq]["status"] = "running"
        self.on_change(sid)

    def finish(self, sid, token, seq):
        self.threads.add(threading.get_ident())
        self.calls.append(("finish", seq))
        t = self.trials[seq]
        t["status"] = "answered"
        t["metrics"] = {"psy": {"correct": t["responses"]["response"] == "2"}}
        self.on_change(sid)

    def answer(self, sid, seq, value):  # the participant's answer, as the engine records it
        self.trials[seq]["responses"] = {"response": value}
        self.on_change(sid)


async def until(condition, timeout_s: float = 5.0) -> None:
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    while not condition():
        assert loop.time() < deadline, "timed out"
        await asyncio.sleep(0.01)


def run(engine: Engine, script) -> list:
    """Run `script(shell, shown)` on an event loop that owns the shell; `shown`: each view published."""
    shown: list = []

    async def main():
        owner = Owner("test")
        owner.bind()
        shell = PacedSessions(engine, owner, lambda sid: shown.append(shell.view(sid)))
        engine.on_change = shell.changed
        await script(shell, shown)

    asyncio.run(main())
    return shown


def test_feedback_from_the_trials_metrics_shows_for_its_time_then_the_next_trial_starts():
    engine = Engine()

    async def script(shell, shown):
        engine.trials[0]["status"] = "running"  # the experimenter started the task
        shell.changed("s1")
        await until(lambda: shown and shown[-1]["state"] == "trial")
        await asyncio.to_thread(engine.answer, "s1", 0, "2")
        await until(lambda: engine.trials[1]["status"] == "running")
        await asyncio.to_thread(engine.answer, "s1", 1, "1")
        await until(lambda: engine.trials[2]["status"] == "running")

    shown = run(engine, script)
    states = [(v["state"], v["feedback"]) for v in shown if v]
    assert ("feedback", "correct") in states and ("feedback", "wrong") in states, states
    first = states.index(("feedback", "correct"))
    assert ("trial", None) in states[first:], "the next trial follows the feedback"
    assert engine.calls == [("finish", 0), ("start", 1), ("finish", 1), ("start", 2)]
    assert threading.main_thread().ident not in engine.threads, "the engine runs on worker threads, off the loop"


def test_a_refused_start_pauses_with_its_reason():
    engine = Engine(refuse_start="device 'ferrovibe' is disconnected")

    async def script(shell, shown):
        engine.trials[0]["status"] = "running"
        shell.changed("s1")
        await asyncio.to_thread(engine.answer, "s1", 0, "2")
        await until(lambda: shell.console_view("s1") and shell.console_view("s1")["state"] == "paused")
        assert "ferrovibe" in shell.console_view("s1")["note"]
        await asyncio.sleep(0.4)

    run(engine, script)
    assert engine.calls == [("finish", 0), ("start", 1)], "tried once, then held for the experimenter"


def test_without_a_control_token_nothing_moves():
    engine = Engine(token=None)

    async def script(shell, shown):
        engine.trials[0]["status"] = "running"
        shell.changed("s1")
        await asyncio.to_thread(engine.answer, "s1", 0, "2")
        await until(lambda: shown and shown[-1]["state"] == "trial")
        await asyncio.sleep(0.3)

    run(engine, script)
    assert engine.calls == [] and engine.trials[0]["status"] == "running"
