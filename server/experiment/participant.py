"""What the study asks of the participant now: the view a participant's page is sent (protocol
v1.5 `ask`, docs/protocol.md). Pure: the engine gathers the session's rows, this decides.

The view names the running trial and, of its questions, those the study marks
`answered_by = "participant"`, each with the answer recorded so far; and the audio and
instructions of the task at hand (the running trial's, else the next pending trial's, so a
study's spoken instructions are on before its first trial starts)."""

from __future__ import annotations

import re
from typing import Any, Mapping, Sequence

from server.experiment.study import NO_AUDIO, Study
from server.experiment.store import TrialRow

# A pseudonymous code, never a name (docs/data.md): with a digit, so "Anna" is refused as "Anna
# Schmidt" is. The console checks the same rule (clients/web/src/console/console.js).
PARTICIPANT_CODE = re.compile(r"^(?=[^0-9]*[0-9])[A-Za-z0-9_-]{1,32}$")
PARTICIPANT_CODE_RULE = ("a pseudonymous code of 1-32 letters, digits, '-' or '_' with at least one digit, "
                         "such as P07 (never a name: no names are stored)")


def participant_code_problem(code: str | None) -> str | None:
    """None for a valid participant code, else what is wrong, in words that say what is allowed."""
    if PARTICIPANT_CODE.match(code or ""):
        return None
    return f"participant must be {PARTICIPANT_CODE_RULE}; got {code!r}"


def participant_view(session_id: str, study: Study | None, trials: Sequence[TrialRow],
                     responses: Mapping[str, Any]) -> dict:
    """`trials`: the session's queue in order; `responses`: the running trial's recorded answers."""
    running = next((t for t in trials if t.status == "running"), None)
    current = running or next((t for t in trials if t.status == "pending"), None)
    task = None
    if study is not None and current is not None:
        try:
            task = study.task(current.task)
        except KeyError:  # the file changed under a session: ask nothing of a task it no longer has
            task = None
    questions = []
    if running is not None and task is not None:
        for qid in running.questions:
            try:
                q = task.question(qid)
            except KeyError:
                continue
            if q.answered_by == "participant":
                questions.append({**q.to_dict(), "answer": responses.get(qid)})
    return {"session": session_id, "seq": None if running is None else running.seq,
            "task": None if current is None else current.task, "questions": questions,
            "audio": (task.audio if task is not None else NO_AUDIO).to_dict(),
            "instructions": task.instructions if task is not None else ""}
