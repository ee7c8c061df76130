"""Randomly interleaved procedures: one per condition (e.g. a staircase per frequency). Each
trial goes to one of the unfinished procedures, drawn uniformly with a generator seeded by
(seed, trial), so the choice is a pure function of the seed and the answers so far."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class InterleavedSpec:
    conditions: tuple      # ((name, spec), ...) in the file's order
    kind: str = "interleaved"


class Interleaved:
    def __init__(self, spec: InterleavedSpec, seed=0, *, start):
        self.spec, self.seed = spec, seed
        # each procedure gets its own seed, derived from the session's and its position
        self.procedures = {name: start(sub, _seed(seed, i)) for i, (name, sub) in enumerate(spec.conditions)}
        self.trial = 0
        self.condition = self._choose()

    def _choose(self) -> str | None:
        open_ = [name for name, p in self.procedures.items() if not p.finished]
        if not open_:
            return None
        return open_[int(np.random.default_rng(_seed(self.seed, self.trial)).integers(len(open_)))]

    @property
    def finished(self) -> bool:
        return self.condition is None

    @property
    def level(self) -> float | None:
        return None if self.finished else self.procedures[self.condition].level

    @property
    def stimulus(self) -> dict | None:
        if self.finished:
            return None
        procedure = self.procedures[self.condition]
        stim = getattr(procedure, "stimulus", None) or {"level": procedure.level}
        return {"condition": self.condition, **stim}

    def update(self, answer) -> None:
        if self.finished:
            raise ValueError("every interleaved procedure has finished: no trial to answer")
        self.procedures[self.condition].update(answer)
        self.trial += 1
        self.condition = self._choose()

    def estimate(self) -> dict:
        return {name: p.estimate() for name, p in self.procedures.items()}

    def record(self) -> dict:
        return {"trial": self.trial, "condition": self.condition, "finished": self.finished,
                "procedures": {name: p.record() for name, p in self.procedures.items()}}


def _seed(seed, i: int) -> list[int]:
    base = list(seed) if isinstance(seed, (list, tuple)) else [int(seed)]
    return [*base, int(i)]
