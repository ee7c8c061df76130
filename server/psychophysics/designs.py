"""Psychophysical designs: how a procedure's level becomes the intervals a participant feels, what
the participant may answer, and whether an answer is correct (docs/psychophysics.md "In a study").

Pure: a trial's random choices (which interval holds the signal, a catch trial, a same or a
different pair) come from a generator seeded with the integer the caller derives for that trial,
so the same trial always presents the same way, after a crash too.

| design | intervals | answers | guess rate | the procedure hears |
|---|---|---|---|---|
| `yes-no` | 1: the level, or on a catch trial the reference | `yes`, `no` | 0 | "yes" on signal trials (catch trials: nothing) |
| `nafc` | n (2–4): the level in one, the reference in the others | `1` … `n` | 1/n | correct |
| `2ifc` | `nafc` with n = 2 | `1`, `2` | 1/2 | correct |
| `same-different` | 2: reference + level in either order, or reference twice | `same`, `different` | 1/2 | correct |
| `identification` | 1: one of the procedure's k levels | the k labels | 1/k | correct |

The reference (the value of the non-signal intervals) is None for a blank interval (marked, no cue).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from server.psychophysics.spec import Fields, SpecError

DESIGNS = ("yes-no", "nafc", "2ifc", "same-different", "identification")
MAX_INTERVALS = 4  # the stimulus scenario's level_1 … level_4
# fields of [tasks.psychophysics] that only some designs read
DESIGN_FIELDS = {"intervals": ("nafc",), "catch_rate": ("yes-no",), "different_rate": ("same-different",),
                 "labels": ("identification",)}


@dataclass(frozen=True)
class Design:
    name: str                      # one of DESIGNS
    intervals: int                 # intervals per trial (C1 n_intervals)
    choices: tuple[str, ...]       # the answers, in the order the participant sees them
    reference: float | None = None  # the non-signal intervals' value (None: blank)
    catch_rate: float = 0.0        # yes-no: share of catch trials (no signal)
    different_rate: float = 0.5    # same-different: share of "different" pairs
    stimuli: tuple[float, ...] = ()  # identification: the k levels, in the order of the labels

    @property
    def guess(self) -> float:
        """The chance of a correct answer without any sensation (yes-no: a "yes" without signal, 0)."""
        return 0.0 if self.name == "yes-no" else 1.0 / len(self.choices)

    def to_dict(self) -> dict:
        return {"design": self.name, "intervals": self.intervals, "choices": list(self.choices),
                "reference": self.reference, "catch_rate": self.catch_rate, "different_rate": self.different_rate,
                "stimuli": list(self.stimuli), "guess": self.guess}


def parse_design(f: Fields, stimuli: tuple[float, ...] = ()) -> Design:
    """The design fields of a `[tasks.psychophysics]` table (`f`, its other fields read by the
    caller). `stimuli`: the procedure's levels (identification presents and labels them)."""
    name = f.choice("design", DESIGNS)
    for field, designs in DESIGN_FIELDS.items():
        if field in f.table and name not in designs:
            raise f.error(field, f"applies to a {' or '.join(designs)} design, not {name}")
    reference = f.number("reference", None)
    if name == "yes-no":
        catch = f.number("catch_rate", 0.0, low=0.0, high=1.0)
        if catch >= 1:
            raise f.error("catch_rate", "must be < 1: a yes-no task needs signal trials")
        return Design(name, 1, ("yes", "no"), reference, catch_rate=float(catch))
    if name in ("nafc", "2ifc"):
        n = 2 if name == "2ifc" else int(f.number("intervals", 3, whole=True))
        if not 2 <= n <= MAX_INTERVALS:
            raise f.error("intervals", f"an nAFC trial needs 2 to {MAX_INTERVALS} intervals (one answer key each), "
                                       f"got {n}")
        return Design(name, n, tuple(str(k) for k in range(1, n + 1)), reference)
    if name == "same-different":
        rate = f.number("different_rate", 0.5, low=0.0, high=1.0, low_open=True)
        if rate >= 1:
            raise f.error("different_rate", "must be < 1: a same-different task needs same pairs")
        if reference is None:
            raise f.error("reference", "missing (required): a same-different pair compares the level with it")
        return Design(name, 2, ("same", "different"), reference, different_rate=float(rate))
    if reference is not None:
        raise f.error("reference", "does not apply to identification (every trial presents one of the k levels)")
    return Design(name, 1, _labels(f, stimuli), stimuli=tuple(stimuli))


def _labels(f: Fields, stimuli: tuple[float, ...]) -> tuple[str, ...]:
    default = tuple(_label(s) for s in stimuli)
    labels = f.table.get("labels", default)
    f.read.add("labels")
    if not isinstance(labels, (list, tuple)) or not all(isinstance(x, str) and x.strip() for x in labels):
        raise f.error("labels", f"expected a list of answer labels (non-empty strings), got {labels!r}")
    if len(labels) < 2:
        raise f.error("labels", f"identification needs at least 2 answers, got {len(labels)}")
    if len(labels) != len(stimuli):
        raise f.error("labels", f"one label per stimulus level: {len(stimuli)} levels, {len(labels)} labels")
    if len(set(labels)) != len(labels):
        raise f.error("labels", f"a label appears twice: {list(labels)}")
    return tuple(labels)


def _label(x: float) -> str:
    return str(int(x)) if float(x).is_integer() else str(x)


@dataclass(frozen=True)
class Presentation:
    """One trial as presented: the value in each interval (None: blank) and what makes an answer right."""
    levels: tuple[float | None, ...]
    target: int | None = None          # nafc/2ifc: the 1-based signal interval
    signal: bool | None = None         # yes-no: signal present; same-different: a different pair
    stimulus_index: int | None = None  # identification: index into the design's stimuli

    def to_dict(self) -> dict:
        return {"levels": list(self.levels), "target": self.target, "signal": self.signal,
                "stimulus_index": self.stimulus_index}


def present(design: Design, level: float, seed: int) -> Presentation:
    """The trial at this level; `seed` (an int the caller derives per trial) draws its order."""
    rng = np.random.default_rng(seed)
    ref = design.reference
    if design.name == "yes-no":
        signal = bool(rng.random() >= design.catch_rate)
        return Presentation((level if signal else ref,), signal=signal)
    if design.name in ("nafc", "2ifc"):
        target = int(rng.integers(design.intervals)) + 1
        return Presentation(tuple(level if k == target else ref for k in range(1, design.intervals + 1)),
                            target=target)
    if design.name == "same-different":
        different = bool(rng.random() < design.different_rate)
        if not different:
            return Presentation((ref, ref), signal=False)
        return Presentation((level, ref) if rng.random() < 0.5 else (ref, level), signal=True)
    index = _index(design.stimuli, level)
    return Presentation((design.stimuli[index],), stimulus_index=index)


def _index(stimuli: tuple[float, ...], level: float) -> int:
    for i, s in enumerate(stimuli):
        if math.isclose(s, level, rel_tol=1e-9, abs_tol=1e-12):
            return i
    raise SpecError(f"level {level!r} is not one of the identification's stimuli {list(stimuli)}")


def correct(design: Design, presentation: Presentation, answer: str) -> bool:
    """Whether `answer` (one of the design's choices) is right for this presentation (yes-no: a
    hit or a correct rejection; same-different: "different" for a different pair)."""
    if design.name == "yes-no":
        return (answer == "yes") == presentation.signal
    if design.name in ("nafc", "2ifc"):
        return answer == str(presentation.target)
    if design.name == "same-different":
        return (answer == "different") == presentation.signal
    return design.choices.index(answer) == presentation.stimulus_index


def outcome(design: Design, presentation: Presentation, answer: str) -> bool | None:
    """What the procedure hears: yes-no tracks p("yes") on signal trials (a catch trial tells it
    nothing: None); every other design tracks p(correct)."""
    if design.name == "yes-no":
        return (answer == "yes") if presentation.signal else None
    return correct(design, presentation, answer)
