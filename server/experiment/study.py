"""Studies as files: the TOML study model, its loading and its validation (docs/studies.md).

A study file describes a whole protocol — tasks in session order, each a scenario with its
settings, the conditions of its main trials, how often and in which order they run, the phases
before them and the questions after them — so the same study runs the same way in any lab.
This module turns the text into frozen dataclasses and nothing else: no clock, no database,
no network. `plan.py` turns a Study and a participant into the ordered trial list.

Theory of operation:
- The file is parsed with `tomllib`; every table is read by `_Table`, which refuses unknown
  fields (with a difflib "did you mean"), missing required fields and wrongly typed values.
  Every error is a StudyError whose message starts with the place: the file, then
  `task "id"`, `block "id"` or `question "id"`, so a lab can fix a file without reading code.
- Scenario names resolve through the scenario registry to the versioned id, which is what the
  Study stores (a later scenario version cannot silently change a recorded study). Scenario
  parameters and trial parameters are checked by the scenario's own Param declarations
  (`server.core.scenario.check_params`), so the file accepts exactly what the scenario accepts and
  stores the values with their defaults filled in.
- `subtask = "name"` borrows the design a scenario already declares (SUBTASKS): conditions,
  practice trials, training time, time limit and the answer as a question. Fields written in
  the file override the borrowed ones.
- `source_hash` (SHA-256 of the text) identifies the exact file a session ran.
- `[tasks.psychophysics]` makes the task a psychophysical procedure on the stimulus scenario
  (server/experiment/psychophysics_task.py): no conditions, `max_trials` main trials whose levels
  the procedure chooses as the session runs, and one generated question, `response`.
"""

from __future__ import annotations

import hashlib
import math
import re
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any, Callable, Mapping

from devices.profiles import AUDIO_PROFILES, PROFILES
from server.core.did_you_mean import did_you_mean as _did_you_mean
from server.core.scenario import ParamError, Param, SubTask, Trial
from scenarios.registry import UnknownScenario, check_scenario_params, resolve
from server.experiment.order import ORDERS
from server.experiment.psychophysics_task import QUESTION_ID, PsyTask, parse_psychophysics
from server.psychophysics.spec import SpecError
from server.experiment.pacing import EXPERIMENTER_PACED, PACED_BY, Pacing
from server.experiment.question import (ANSWERERS, PARTICIPANT_KINDS, QUESTION_KINDS, Question, as_number,
                                        format_bound, frozen_mapping, question_from_answer)

BLOCK_ORDERS = ("latin", "fixed", "random")
DEVICE_MODELS = tuple(PROFILES) + tuple(AUDIO_PROFILES)  # the built-in device profiles (devices/profiles.py)
_ID = re.compile(r"[a-z0-9_]+\Z")
_STUDY_ID = re.compile(r"[a-z0-9][a-z0-9_-]*\Z")  # like a file name: "thesis-2021"
_REQUIRED = object()


class StudyError(ValueError):
    """A study file that cannot be used; the message starts with where the problem is."""


# ---- tasks, blocks, study --------------------------------------------------------------------

@dataclass(frozen=True)
class Audio:
    """What the participant's page plays (docs/xr.md "In XR: panels, answers, audio"): off unless the study turns it on."""
    speech: bool = False           # speak each new instruction (Web Speech API where present)
    contact_sounds: bool = False   # a short click at each contact onset

    def to_dict(self) -> dict:
        return {"speech": self.speech, "contact_sounds": self.contact_sounds}


NO_AUDIO = Audio()


@dataclass(frozen=True)
class Task:
    id: str                                    # unique in the study, [a-z0-9_]+
    title: str
    scenario: str                              # versioned registry id, e.g. "contact-angle-v1"
    device: str | None                         # device model the task is for (DEVICE_MODELS), or None
    params: Mapping[str, Any]                  # the scenario's PARAMS, checked, defaults filled
    conditions: tuple[Mapping[str, Any], ...]  # TRIAL_PARAMS of each main trial, checked
    repetitions: int = 1                       # each condition this many times
    order: str = "random"                      # "fixed" | "random" | "latin" (order.py)
    practice: int = 0                          # trial-phase trials, drawn (seeded) from the conditions
    training_s: float = 0.0                    # training (free exploration) time, s; 0 = no training
    time_limit_s: float | None = None          # per trial-phase and main trial, s; None = until answered
    questions: tuple[Question, ...] = ()       # asked after every trial-phase and main trial
    end_questions: tuple[Question, ...] = ()   # the task's questionnaire, once after its last main trial
    block: str | None = None                   # the counterbalanced block listing this task (from [[blocks]])
    subtask: str | None = None                 # the scenario SUBTASKS entry the defaults came from
    instructions: str = ""                     # what the experimenter reads out or shows (added)
    training_conditions: tuple[Mapping[str, Any], ...] = ()  # training-phase trials sharing training_s (added)
    audio: Audio = NO_AUDIO                    # the study's [audio], with this task's [tasks.audio] over it (added)
    psychophysics: PsyTask | None = None       # [tasks.psychophysics]: levels chosen by a procedure (added)
    pacing: Pacing = EXPERIMENTER_PACED        # [tasks.pacing]: who moves the trials on (pacing.py)

    def question(self, question_id: str) -> Question:
        """A question of this task (per trial or end of task) by id; KeyError if there is none."""
        for q in self.questions + self.end_questions:
            if q.id == question_id:
                return q
        raise KeyError(f"task {self.id!r} has no question {question_id!r}")

    def to_dict(self) -> dict:
        return {"id": self.id, "title": self.title, "scenario": self.scenario, "device": self.device,
                "params": dict(self.params), "conditions": [dict(c) for c in self.conditions],
                "repetitions": self.repetitions, "order": self.order, "practice": self.practice,
                "training_s": self.training_s, "time_limit_s": self.time_limit_s,
                "questions": [q.to_dict() for q in self.questions],
                "end_questions": [q.to_dict() for q in self.end_questions], "block": self.block,
                "subtask": self.subtask, "instructions": self.instructions,
                "training_conditions": [dict(c) for c in self.training_conditions], "audio": self.audio.to_dict(),
                "psychophysics": self.psychophysics.to_dict() if self.psychophysics else None,
                "pacing": self.pacing.to_dict()}


@dataclass(frozen=True)
class Block:
    id: str
    tasks: tuple[str, ...]   # task ids; this order names the Latin square's items (row 0 = as listed)
    order: str = "latin"     # "latin" | "fixed" | "random" (seeded per participant, added)

    def to_dict(self) -> dict:
        return {"id": self.id, "tasks": list(self.tasks), "order": self.order}


@dataclass(frozen=True)
class Study:
    id: str
    title: str
    version: int
    seed: int
    participants: int           # planned number of participants
    tasks: tuple[Task, ...]     # file order = session order (blocks permute their tasks' positions)
    blocks: tuple[Block, ...]
    source_hash: str            # SHA-256 (hex) of the file text
    description: str = ""       # (added)
    audio: Audio = NO_AUDIO     # the study's [audio] (each task carries its own, resolved)

    def task(self, task_id: str) -> Task:
        for t in self.tasks:
            if t.id == task_id:
                return t
        raise KeyError(f"study {self.id!r} has no task {task_id!r}")

    def to_dict(self) -> dict:
        return {"id": self.id, "title": self.title, "version": self.version, "seed": self.seed,
                "participants": self.participants, "description": self.description,
                "source_hash": self.source_hash, "audio": self.audio.to_dict(),
                "tasks": [t.to_dict() for t in self.tasks],
                "blocks": [b.to_dict() for b in self.blocks]}


# ---- reading tables --------------------------------------------------------------------------

class _Table:
    """One TOML table being read: unknown and missing fields are errors, values are type-checked."""

    def __init__(self, raw: Any, where: str, fields: tuple[str, ...], required: tuple[str, ...] = ()):
        if not isinstance(raw, dict):
            raise StudyError(f"{where}: must be a table, got {type(raw).__name__}")
        self.raw, self.where = raw, where
        for name in raw:
            if name not in fields:
                raise StudyError(f"{where}: unknown field {name!r}{_did_you_mean(name, fields)}")
        for name in required:
            if name not in raw:
                raise StudyError(f"{where}: missing required field {name!r}")

    def has(self, name: str) -> bool:
        return name in self.raw

    def error(self, message: str) -> StudyError:
        return StudyError(f"{self.where}: {message}")

    def get(self, name: str, check: Callable[[Any], Any], want: str, default: Any = _REQUIRED) -> Any:
        if name not in self.raw:
            return default
        value = self.raw[name]
        try:
            return check(value)
        except (TypeError, ValueError):
            raise self.error(f"{name} must be {want}, got {value!r}") from None

    def text(self, name: str, default: Any = _REQUIRED) -> str:
        return self.get(name, _is(str), "a string", default)

    def ident(self, name: str, default: Any = _REQUIRED) -> str:
        return self.get(name, _matching(_ID), "an id of lower-case letters, digits and _", default)

    def integer(self, name: str, low: float, default: Any = _REQUIRED) -> int:
        return self.get(name, _at_least(low, whole=True), _want("a whole number", low), default)

    def number(self, name: str, low: float, default: Any = _REQUIRED) -> float:
        return self.get(name, _at_least(low, whole=False), _want("a number", low), default)

    def flag(self, name: str, default: bool) -> bool:
        return self.get(name, _is(bool), "true or false", default)

    def tables(self, name: str) -> list:
        return self.get(name, _is(list), "an array of tables", [])


def _is(kind: type) -> Callable[[Any], Any]:
    def check(value):
        if not isinstance(value, kind) or (kind is not bool and isinstance(value, bool)):
            raise TypeError
        return value
    return check


def _want(what: str, low: float) -> str:
    return what if low == -math.inf else f"{what} >= {format_bound(low)}"


def _matching(pattern: re.Pattern) -> Callable[[Any], str]:
    def check(value):
        if not isinstance(value, str) or not pattern.match(value):
            raise ValueError
        return value
    return check


def _at_least(low: float, whole: bool) -> Callable[[Any], Any]:
    def check(value):
        n = as_number(value) if not isinstance(value, str) else None
        if n is None or n < low or (whole and not float(n).is_integer()):
            raise ValueError
        return int(n) if whole else float(n)
    return check


# ---- parsing ---------------------------------------------------------------------------------

STUDY_FIELDS = ("id", "title", "version", "seed", "participants", "description", "tasks", "blocks", "audio")
TASK_FIELDS = ("id", "title", "scenario", "device", "params", "subtask", "conditions", "repetitions", "order",
               "practice", "training_s", "training_conditions", "time_limit_s", "questions", "end_questions",
               "instructions", "audio", "psychophysics", "pacing")
PACING_FIELDS = ("by", "iti_ms", "feedback", "feedback_ms", "break_every")
BLOCK_FIELDS = ("id", "tasks", "order")
AUDIO_FIELDS = ("speech", "contact_sounds")
QUESTION_FIELDS = ("id", "kind", "text", "low", "high", "integer", "labels", "choices", "required", "answered_by")
KIND_FIELDS = {"likert": ("low", "high", "labels"), "number": ("low", "high", "integer"),
               "choice": ("choices",), "text": ()}


def load_study(path) -> Study:
    """The study in a TOML file (StudyError names the file and the place of any problem)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise StudyError(f"{path}: cannot read the study file ({exc.strerror or exc})") from None
    return parse_study(text, str(path))


def parse_study(text: str, name: str = "<study>") -> Study:
    """The study in TOML `text`; `name` (usually the file) starts every error message."""
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise StudyError(f"{name}: not valid TOML: {exc}") from None
    top = _Table(doc, name, STUDY_FIELDS, ("id", "title", "seed", "participants", "tasks"))
    head = {"id": top.get("id", _matching(_STUDY_ID), "an id of lower-case letters, digits, - and _"),
            "title": top.text("title"), "version": top.integer("version", 1, 1), "seed": top.integer("seed", 0),
            "participants": top.integer("participants", 1), "description": top.text("description", "")}
    audio = _audio(top, NO_AUDIO)
    tasks = tuple(_parse_task(raw, f"{name}: task #{i + 1}", name, audio)
                  for i, raw in enumerate(top.tables("tasks")))
    if not tasks:
        raise top.error("a study needs at least one [[tasks]] table")
    _unique((t.id for t in tasks), f"{name}: task")
    blocks = tuple(_parse_block(raw, f"{name}: block #{i + 1}", name) for i, raw in enumerate(top.tables("blocks")))
    _unique((b.id for b in blocks), f"{name}: block")
    return Study(**head, audio=audio, tasks=_assign_blocks(tasks, blocks, name), blocks=blocks,
                 source_hash=hashlib.sha256(text.encode("utf-8")).hexdigest())


def _unique(ids, what: str) -> None:
    seen = set()
    for i in ids:
        if i in seen:
            raise StudyError(f"{what} id {i!r} is used twice")
        seen.add(i)


def _audio(t: _Table, default: Audio) -> Audio:
    """An `[audio]` table (study or task): each field given overrides `default`'s."""
    if not t.has("audio"):
        return default
    a = _Table(t.raw["audio"], f"{t.where}: audio", AUDIO_FIELDS)
    return Audio(speech=a.flag("speech", default.speech), contact_sounds=a.flag("contact_sounds", default.contact_sounds))


def _parse_task(raw: Any, where: str, name: str, audio: Audio = NO_AUDIO) -> Task:
    if isinstance(raw, dict) and isinstance(raw.get("id"), str):
        where = f'{name}: task "{raw["id"]}"'  # name the task as soon as it has a name
    if isinstance(raw, dict) and "block" in raw:
        raise StudyError(f"{where}: a task joins a block by being listed in that [[blocks]] table's tasks")
    t = _Table(raw, where, TASK_FIELDS, ("id", "scenario"))
    try:
        spec = resolve(t.text("scenario"))
    except UnknownScenario as exc:
        raise t.error(str(exc)) from None
    sub = _subtask(t, spec.id, spec.factory.SUBTASKS)
    params = _checked(t, lambda: check_scenario_params(spec, t.get("params", _is(dict), "a table", {})), "params: ")
    trial_specs = spec.factory.TRIAL_PARAMS
    conditions = _conditions(t, "conditions", "main", trial_specs, sub.conditions if sub else None)
    training_conditions = _conditions(t, "training_conditions", "training", trial_specs, ())
    psy = _psychophysics(t, spec, params)
    task = Task(
        id=t.ident("id"), title=t.text("title", sub.title if sub else spec.title), scenario=spec.id,
        device=_device(t), params=frozen_mapping(params), conditions=conditions,
        repetitions=t.integer("repetitions", 1, 1), order=_choice(t, "order", ORDERS, "random"),
        practice=t.integer("practice", 0, sub.practice_trials if sub else 0),
        training_s=t.number("training_s", 0.0, sub.training_s if sub else 0.0),
        time_limit_s=_time_limit(t, sub.time_limit_s if sub else None),
        questions=_psy_questions(psy) + _questions(t, "questions", () if psy else _subtask_questions(sub)),
        end_questions=_questions(t, "end_questions", ()), subtask=sub.name if sub else None,
        instructions=t.text("instructions", ""), training_conditions=training_conditions, audio=_audio(t, audio),
        psychophysics=psy, pacing=_pacing(t))
    _check_task(t, task)
    _check_pacing(t, task)
    return task


def _psychophysics(t: _Table, spec, params: Mapping) -> PsyTask | None:
    """The task's [tasks.psychophysics] table (server/experiment/psychophysics_task.py), or None."""
    if not t.has("psychophysics"):
        return None
    for name in ("conditions", "repetitions", "order", "subtask"):
        if t.has(name):
            raise t.error(f"{name}: a psychophysics task's trials come from its procedure (max_trials in "
                          "[tasks.psychophysics]); leave out conditions, repetitions, order and subtask")
    try:
        return parse_psychophysics(t.raw["psychophysics"], f"{t.where}: psychophysics", spec.id,
                                   spec.factory.TRIAL_PARAMS, lambda p: check_scenario_params(spec, p), params,
                                   _device(t))
    except (SpecError, ParamError) as exc:
        raise StudyError(str(exc)) from None


def _psy_questions(psy: PsyTask | None) -> tuple[Question, ...]:
    """The generated question of a psychophysics task: the participant chooses one of the design's answers."""
    if psy is None:
        return ()
    text = {"yes-no": "Did you feel it?", "same-different": "Were the two the same or different?",
            "identification": "Which one was it?"}.get(psy.design.name, "Which interval held the stimulus?")
    return (Question(QUESTION_ID, "choice", text, choices=psy.design.choices, answered_by="participant"),)


def _checked(t: _Table, make: Callable[[], Any], prefix: str = "") -> Any:
    try:
        return make()
    except ParamError as exc:  # the scenario's own message, prefixed with the task
        raise t.error(f"{prefix}{exc}") from None


def _subtask(t: _Table, scenario: str, declared: tuple[SubTask, ...]) -> SubTask | None:
    wanted = t.text("subtask", None)
    if wanted is None:
        return None
    for sub in declared:
        if sub.name == wanted:
            return sub
    names = [s.name for s in declared]
    raise t.error(f"{scenario} declares no subtask {wanted!r}"
                  f"{_did_you_mean(wanted, names) if names else ' (it declares none)'}")


def _subtask_questions(sub: SubTask | None) -> tuple[Question, ...]:
    return (question_from_answer(sub.answer, sub.question),) if sub and sub.answer else ()


def _conditions(t: _Table, name: str, phase: str, specs: tuple[Param, ...], default) -> tuple[Mapping, ...]:
    raws = t.tables(name) if t.has(name) else list(default or ())
    out = []
    for i, raw in enumerate(raws):
        if not isinstance(raw, dict):
            raise t.error(f"{name}[{i}] must be a table of trial parameters, got {raw!r}")
        out.append(_checked(t, lambda raw=raw, i=i: Trial.parse(specs, phase, raw, where=f"{name}[{i}]").params))
    return tuple(out)


def _device(t: _Table) -> str | None:
    device = t.text("device", None)
    if device is not None and device not in DEVICE_MODELS:
        raise t.error(f"unknown device model {device!r}{_did_you_mean(device, DEVICE_MODELS)}")
    return device


def _choice(t: _Table, name: str, allowed: tuple[str, ...], default: str) -> str:
    value = t.text(name, default)
    if value not in allowed:
        raise t.error(f"unknown {name} {value!r}{_did_you_mean(value, allowed)}")
    return value


def _time_limit(t: _Table, default: float | None) -> float | None:
    limit = t.number("time_limit_s", 0.0, default)
    return None if limit == 0 else limit  # 0 in the file: no limit (TOML has no null)


def _check_task(t: _Table, task: Task) -> None:
    n = len(task.conditions)
    _unique((q.id for q in task.questions + task.end_questions), f"{t.where}: question")
    if task.psychophysics is not None:
        return  # its trials are the procedure's (plan.py); practice uses its practice levels
    if task.order == "latin" and n < 2:
        raise t.error(f'order "latin" needs at least 2 conditions, got {n}')
    if task.practice and not n:
        raise t.error("practice trials are drawn from the conditions, and this task has none")
    if task.training_conditions and not task.training_s:
        raise t.error("training_conditions need a training time (training_s > 0)")
    if not (n or task.training_s or task.end_questions):
        raise t.error("nothing to do: give conditions, a training time or end_questions")


def _check_pacing(t: _Table, task: Task) -> None:
    """A participant-paced task: nobody at the console answers between its trials."""
    if not task.pacing.paced:
        return
    for q in task.questions:
        if q.answered_by != "participant":
            raise t.error(f'pacing: by = "participant" needs every per-trial question answered by the participant; '
                          f'question "{q.id}" is answered by the experimenter (set answered_by = "participant" '
                          f"or move it to end_questions)")
    if not any(q.required for q in task.questions):
        raise t.error('pacing: by = "participant" needs a required question the participant answers (its answer '
                      "ends each trial)")


def _pacing(t: _Table) -> Pacing:
    """A task's `[tasks.pacing]` (docs/studies.md "Participant-paced tasks")."""
    if not t.has("pacing"):
        return EXPERIMENTER_PACED
    p = _Table(t.raw["pacing"], f"{t.where}: pacing", PACING_FIELDS)
    d = EXPERIMENTER_PACED
    return Pacing(by=_choice(p, "by", PACED_BY, d.by), iti_ms=p.integer("iti_ms", 0, d.iti_ms),
                  feedback=p.flag("feedback", d.feedback), feedback_ms=p.integer("feedback_ms", 0, d.feedback_ms),
                  break_every=p.integer("break_every", 0, d.break_every))


def _questions(t: _Table, name: str, default: tuple[Question, ...]) -> tuple[Question, ...]:
    if not t.has(name):
        return default
    return tuple(_parse_question(raw, f"{t.where}: {name}[{i}]") for i, raw in enumerate(t.tables(name)))


def _parse_question(raw: Any, where: str) -> Question:
    if isinstance(raw, dict) and isinstance(raw.get("id"), str):
        where = f'{where.rsplit(": ", 1)[0]}: question "{raw["id"]}"'
    q = _Table(raw, where, QUESTION_FIELDS, ("id", "kind", "text"))
    kind = _choice(q, "kind", QUESTION_KINDS, "text")
    for name in raw:
        if name in QUESTION_FIELDS[3:] and name not in ("required", "answered_by") and name not in KIND_FIELDS[kind]:
            raise q.error(f"field {name!r} does not apply to a {kind} question")
    low, high = _bounds(q, kind)
    choices = _choices(q) if kind == "choice" else ()
    answered_by = _choice(q, "answered_by", ANSWERERS, "experimenter")
    if answered_by == "participant" and kind not in PARTICIPANT_KINDS:
        raise q.error(f'answered_by = "participant" needs a {", ".join(PARTICIPANT_KINDS)} question (the participant '
                      f"chooses on a panel); a {kind} question is answered by the experimenter")
    return Question(id=q.ident("id"), kind=kind, text=q.text("text"), low=low, high=high,
                    integer=q.flag("integer", False), labels=_labels(q, low, high), choices=choices,
                    required=q.flag("required", True), answered_by=answered_by)


def _bounds(q: _Table, kind: str) -> tuple[float | None, float | None]:
    if kind == "likert":
        low, high = q.integer("low", -math.inf, 1), q.integer("high", -math.inf, 7)
    elif kind == "number":
        low, high = q.number("low", -math.inf, None), q.number("high", -math.inf, None)
    else:
        return None, None
    if low is not None and high is not None and low >= high:
        raise q.error(f"low ({format_bound(low)}) must be below high ({format_bound(high)})")
    return low, high


def _labels(q: _Table, low, high) -> Mapping[int, str]:
    raw = q.get("labels", _is(dict), "a table of point = \"anchor\"", {})
    labels = {}
    for key, text in raw.items():
        if not re.fullmatch(r"-?\d+", key) or not low <= int(key) <= high or not isinstance(text, str):
            raise q.error(f"labels: {key} = {text!r} must name a scale point from {low} to {high} with a string")
        labels[int(key)] = text
    return MappingProxyType(dict(sorted(labels.items())))


def _choices(q: _Table) -> tuple:
    choices = q.get("choices", _is(list), "an array", ())
    for c in choices:
        if isinstance(c, bool) or not isinstance(c, (str, int, float)):
            raise q.error(f"choices must be strings or numbers, got {c!r}")
    if len(choices) < 2:
        raise q.error(f"a choice question needs at least 2 choices, got {len(choices)}")
    if len(set(choices)) < len(choices):
        raise q.error("choices must differ from each other")
    return tuple(choices)


def _parse_block(raw: Any, where: str, name: str) -> Block:
    if isinstance(raw, dict) and isinstance(raw.get("id"), str):
        where = f'{name}: block "{raw["id"]}"'
    b = _Table(raw, where, BLOCK_FIELDS, ("id", "tasks"))
    tasks = b.get("tasks", lambda v: tuple(map(_matching(_ID), _is(list)(v))), "an array of task ids")
    if len(tasks) < 2:
        raise b.error(f"a block counterbalances at least 2 tasks, got {len(tasks)}")
    return Block(id=b.ident("id"), tasks=tasks, order=_choice(b, "order", BLOCK_ORDERS, "latin"))


def _assign_blocks(tasks: tuple[Task, ...], blocks: tuple[Block, ...], name: str) -> tuple[Task, ...]:
    """Each task learns its block; a block may only name known tasks, a task join one block."""
    owner: dict[str, str] = {}
    known = [t.id for t in tasks]
    for block in blocks:
        for tid in block.tasks:
            if tid not in known:
                raise StudyError(f'{name}: block "{block.id}": unknown task {tid!r}{_did_you_mean(tid, known)}')
            if tid in owner:
                raise StudyError(f'{name}: block "{block.id}": task {tid!r} is already in block "{owner[tid]}"')
            owner[tid] = block.id
    return tuple(_with_block(t, owner.get(t.id)) for t in tasks)


def _with_block(task: Task, block: str | None) -> Task:
    return replace(task, block=block) if block else task
