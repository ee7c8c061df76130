"""Questions of a study: what a participant is asked after a trial or a task, and the check of
an answer against it (Likert with anchor labels, number, forced choice, free text).

An answer is normalised to the form the question declares (an int for a Likert point, the
declared choice for "500" or 500), so the stored value and the exported column never depend on
how a console typed it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping

from server.core.numbers import is_finite_number
from server.core.scenario import Param

QUESTION_KINDS = ("likert", "number", "choice", "text")
ANSWERERS = ("experimenter", "participant")  # who enters a question's answer (docs/studies.md)
PARTICIPANT_KINDS = ("likert", "number", "choice")  # a participant answers by choosing, not typing
TEXT_ANSWER_MAX = 2000                 # characters of a free-text answer


class AnswerError(ValueError):
    """A response that does not fit its question; the message names the question and the rule."""


def frozen_mapping(mapping: Mapping | None) -> Mapping:
    """A read-only copy (study data never changes after loading)."""
    return MappingProxyType(dict(mapping or {}))


def format_bound(x: float) -> str:
    """1.0 → "1", 0.5 → "0.5": bounds read as the participant wrote them."""
    return str(int(x)) if float(x).is_integer() else str(x)


def as_number(value: Any) -> float | int | None:
    """A finite number from a number or a numeric string (a console may send text), else None."""
    if isinstance(value, str):
        try:
            value = float(value.strip())
        except ValueError:
            return None
    if is_finite_number(value):
        return value
    return None


@dataclass(frozen=True)
class Question:
    id: str                      # unique within its task, [a-z0-9_]+
    kind: str                    # one of QUESTION_KINDS
    text: str                    # what the participant is asked
    low: float | None = None     # likert: lowest point (default 1); number: optional minimum
    high: float | None = None    # likert: highest point (default 7); number: optional maximum
    integer: bool = False        # number: whole numbers only (a likert answer is always whole)
    labels: Mapping[int, str] = field(default_factory=lambda: MappingProxyType({}))  # likert anchors
    choices: tuple = ()          # choice: the options as declared (strings or numbers)
    required: bool = True        # False: may be left unanswered (None)
    answered_by: str = "experimenter"  # or "participant": chosen on the participant's page or in XR

    def __post_init__(self) -> None:
        if self.kind not in QUESTION_KINDS:
            raise ValueError(f"question {self.id}: kind must be one of {', '.join(QUESTION_KINDS)}")
        if self.answered_by not in ANSWERERS:
            raise ValueError(f"question {self.id}: answered_by must be one of {', '.join(ANSWERERS)}")
        if self.answered_by == "participant" and self.kind not in PARTICIPANT_KINDS:
            raise ValueError(f"question {self.id}: a participant answers a {' or '.join(PARTICIPANT_KINDS)} question "
                             f"by choosing; a {self.kind} question is the experimenter's")
        if self.kind == "likert":  # the 7-point default, so Question(id, "likert", text) is 1..7
            object.__setattr__(self, "low", 1 if self.low is None else self.low)
            object.__setattr__(self, "high", 7 if self.high is None else self.high)
        object.__setattr__(self, "labels", frozen_mapping(self.labels))
        object.__setattr__(self, "choices", tuple(self.choices))

    def check(self, value: Any) -> Any:
        """The answer normalised (int for likert, int/float for number, the choice as declared,
        a string for text), or AnswerError saying what would fit."""
        if value is None or (isinstance(value, str) and not value.strip()):
            if self.required:
                raise AnswerError(f"{self.id}: an answer is required")
            return None
        return {"likert": self._check_scale, "number": self._check_scale,
                "choice": self._check_choice, "text": self._check_text}[self.kind](value)

    def _check_scale(self, value: Any) -> int | float:
        whole = self.kind == "likert" or self.integer
        n = as_number(value)
        fits = n is not None and (not whole or float(n).is_integer()) and \
            (self.low is None or n >= self.low) and (self.high is None or n <= self.high)
        if not fits:
            raise AnswerError(f"{self.id} must be {'a whole number' if whole else 'a number'}{self._range()}, "
                              f"got {value!r}")
        return int(n) if whole else float(n)

    def _range(self) -> str:
        if self.low is not None and self.high is not None:
            return f" from {format_bound(self.low)} to {format_bound(self.high)}"
        if self.low is not None:
            return f" of at least {format_bound(self.low)}"
        return f" of at most {format_bound(self.high)}" if self.high is not None else ""

    def _check_choice(self, value: Any) -> Any:
        for choice in self.choices:
            if isinstance(choice, str) and isinstance(value, str) and value.strip() == choice:
                return choice
            if not isinstance(choice, str) and as_number(value) == choice:
                return choice  # 500 or "500" → 500.0, the declared form
        raise AnswerError(f"{self.id} must be one of {', '.join(map(repr, self.choices))}, got {value!r}")

    def _check_text(self, value: Any) -> str:
        if not isinstance(value, str) or len(value) > TEXT_ANSWER_MAX:
            raise AnswerError(f"{self.id} must be a text of at most {TEXT_ANSWER_MAX} characters")
        return value

    def to_dict(self) -> dict:
        return {"id": self.id, "kind": self.kind, "text": self.text, "low": self.low, "high": self.high,
                "integer": self.integer, "labels": {str(k): v for k, v in self.labels.items()},
                "choices": list(self.choices), "required": self.required, "answered_by": self.answered_by}


def question_from_answer(answer: Param, text: str) -> Question:
    """A scenario's SubTask answer Param as a question: a 1..7 int with anchor labels is a Likert
    item, any other int a whole number, a number a number, a choice a choice (bool → yes/no,
    text → free text)."""
    text = text or answer.doc
    if answer.kind == "int":
        if answer.labels and (answer.low, answer.high) == (1, 7):
            return Question(answer.name, "likert", text, 1, 7, labels=frozen_mapping(answer.labels))
        return Question(answer.name, "number", text, answer.low, answer.high, integer=True)
    if answer.kind == "number":
        return Question(answer.name, "number", text, answer.low, answer.high)
    if answer.kind == "choice":
        return Question(answer.name, "choice", text, choices=tuple(answer.choices))
    if answer.kind == "bool":
        return Question(answer.name, "choice", text, choices=("yes", "no"))
    return Question(answer.name, "text", text)
