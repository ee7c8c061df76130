"""A participant's session plan: Study + participant index → the ordered list of planned trials.

Pure and deterministic: the plan depends on the study (its seed included) and the participant's
0-based index only, so it can be recomputed at any time — after a crash the engine recomputes
it and resumes at the first item without a recorded result.

Theory of operation:
1. Task order (`task_order`): tasks run in file order, except that the tasks of a block are
   permuted among the positions they occupy in the file: the participant's row of the block's
   order (order.py) over the block's tasks as listed. Two tasks A, B under "latin" give AB for
   even participant indices and BA for odd ones (13 participants → 7 AB, 6 BA).
2. Each task expands into phases (server.core.scenario.PHASES), then its questionnaire:
   - training: one item of `training_s` (free exploration, no trial set), or one item per
     training condition, which share `training_s` evenly;
   - trial (practice): `practice` items whose conditions are drawn from the main conditions by
     seeded permutations (seed parts: study seed, participant, task, "practice", cycle), cycling
     if there are more practice trials than conditions;
   - main: each repetition presents every condition once, in the task's order: "fixed" as
     written, "random" with seed parts (study seed, participant, task, repetition), "latin"
     the participant's row of the balanced Latin square, the same row in every repetition;
   - questionnaire: one item with the task's end_questions, if it has any.
   A psychophysics task ([tasks.psychophysics]) plans `practice` trial-phase items and
   `max_trials` main items whose levels are not known yet: the engine fills in each trial's
   parameters when it starts (a replay of the answers so far, server/experiment/psychophysics_task.py);
   the plan holds the driven parameter, the number of intervals and blank levels.
3. `seq` numbers the items 0.. over the whole session; `index` counts within task and kind.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping

from server.experiment.order import order_for, seeded_permutation
from server.experiment.study import Study, Task
from server.psychophysics.designs import MAX_INTERVALS

KINDS = ("training", "trial", "main", "questionnaire")


@dataclass(frozen=True)
class PlannedTrial:
    seq: int                          # 0-based position in the session
    task: str                         # task id
    kind: str                         # one of KINDS (the first three are server.core.scenario.PHASES)
    index: int                        # 0-based number within its task and kind
    scenario: str                     # versioned scenario id
    scenario_params: Mapping[str, Any]
    device: str | None
    params: Mapping[str, Any]         # TRIAL_PARAMS ({} for plain training and questionnaire)
    condition: int | None             # index into task.conditions (trial and main), else None
    repetition: int                   # 0-based (practice: the cycle through the conditions)
    duration_s: float | None          # training: its time; trial/main: the time limit; else None
    questions: tuple[str, ...] = field(default=())  # question ids to answer for this item

    def to_dict(self) -> dict:
        return {"seq": self.seq, "task": self.task, "kind": self.kind, "index": self.index,
                "scenario": self.scenario, "scenario_params": dict(self.scenario_params), "device": self.device,
                "params": dict(self.params), "condition": self.condition, "repetition": self.repetition,
                "duration_s": self.duration_s, "questions": list(self.questions)}


_NO_PARAMS: Mapping[str, Any] = MappingProxyType({})


def task_order(study: Study, participant_index: int) -> tuple[Task, ...]:
    """The study's tasks in this participant's session order (blocks counterbalanced)."""
    _check_participant(participant_index)
    slots = list(study.tasks)
    for block in study.blocks:
        positions = [i for i, t in enumerate(study.tasks) if t.block == block.id]
        members = [study.task(tid) for tid in block.tasks]
        row = order_for(block.order, len(members), participant_index,
                        (study.seed, participant_index, "block", block.id))
        for position, k in zip(positions, row):
            slots[position] = members[k]
    return tuple(slots)


def plan_session(study: Study, participant_index: int) -> tuple[PlannedTrial, ...]:
    """Every item of one participant's session, in order."""
    items: list[PlannedTrial] = []
    for task in task_order(study, participant_index):
        for kind, index, params, condition, repetition, duration, questions in _task_items(
                study, task, participant_index):
            items.append(PlannedTrial(len(items), task.id, kind, index, task.scenario, task.params, task.device,
                                      params, condition, repetition, duration, questions))
    return tuple(items)


def _task_items(study: Study, task: Task, participant_index: int):
    """(kind, index, params, condition, repetition, duration_s, questions) of one task, in order."""
    asked = tuple(q.id for q in task.questions)
    if task.training_conditions:
        share = task.training_s / len(task.training_conditions)
        for k, params in enumerate(task.training_conditions):
            yield "training", k, params, None, 0, share, ()
    elif task.training_s:
        yield "training", 0, _NO_PARAMS, None, 0, task.training_s, ()
    if task.psychophysics is not None:
        yield from _psychophysics_items(task, asked)
        return
    for k, (condition, cycle) in enumerate(practice_draw(study, task, participant_index)):
        yield "trial", k, task.conditions[condition], condition, cycle, task.time_limit_s, asked
    for k, (condition, repetition) in enumerate(main_order(study, task, participant_index)):
        yield "main", k, task.conditions[condition], condition, repetition, task.time_limit_s, asked
    if task.end_questions:
        yield "questionnaire", 0, _NO_PARAMS, None, 0, None, tuple(q.id for q in task.end_questions)


def _psychophysics_items(task: Task, asked: tuple[str, ...]):
    psy = task.psychophysics
    unknown = MappingProxyType({"parameter": psy.parameter, "n_intervals": psy.design.intervals,
                                **{f"level_{k}": None for k in range(1, MAX_INTERVALS + 1)}})
    for k in range(task.practice):
        yield "trial", k, unknown, None, 0, task.time_limit_s, asked
    for k in range(psy.max_trials):
        yield "main", k, unknown, None, 0, task.time_limit_s, asked
    if task.end_questions:
        yield "questionnaire", 0, _NO_PARAMS, None, 0, None, tuple(q.id for q in task.end_questions)


def main_order(study: Study, task: Task, participant_index: int) -> list[tuple[int, int]]:
    """(condition, repetition) of each main trial: every repetition shows every condition once."""
    n = len(task.conditions)
    return [(condition, repetition) for repetition in range(task.repetitions)
            for condition in order_for(task.order, n, participant_index,
                                       (study.seed, participant_index, task.id, repetition))]


def practice_draw(study: Study, task: Task, participant_index: int) -> list[tuple[int, int]]:
    """(condition, cycle) of each practice trial: seeded draws without replacement from the main
    conditions, a fresh permutation per cycle when there are more practice trials than conditions."""
    n, out, cycle = len(task.conditions), [], 0
    while len(out) < task.practice:
        drawn = seeded_permutation(range(n), (study.seed, participant_index, task.id, "practice", cycle))
        out += [(c, cycle) for c in drawn[:task.practice - len(out)]]
        cycle += 1
    return out


def _check_participant(participant_index: int) -> None:
    if isinstance(participant_index, bool) or not isinstance(participant_index, int) or participant_index < 0:
        raise ValueError(f"participant_index must be an integer >= 0, got {participant_index!r}")
