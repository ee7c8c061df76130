"""The method of constant stimuli: every level `repeats` times, in an order drawn once from the
seed (shuffled whole, or `blocked`: each level once per block, each block shuffled)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from server.psychophysics.spec import Fields


@dataclass(frozen=True)
class ConstantSpec:
    levels: tuple
    repeats: int
    blocked: bool
    kind: str = "constant"

    @classmethod
    def parse(cls, table, where: str = "procedure") -> "ConstantSpec":
        f = Fields(table, where)
        f.choice("kind", ("constant",))
        levels = f.numbers("levels")
        if len(set(levels)) != len(levels):
            raise f.error("levels", f"a level appears twice: {list(levels)}")
        repeats = int(f.number("repeats", low=1, whole=True))
        order = f.choice("order", ("random", "blocked"), "random")
        f.done()
        return cls(levels, repeats, order == "blocked")


class ConstantStimuli:
    def __init__(self, spec: ConstantSpec, seed=0):
        self.spec = spec
        rng = np.random.default_rng(seed)
        n = len(spec.levels)
        if spec.blocked:
            order = np.concatenate([rng.permutation(n) for _ in range(spec.repeats)])
        else:
            order = rng.permutation(np.tile(np.arange(n), spec.repeats))
        self.order = tuple(int(i) for i in order)
        self.trial = 0
        self.counts = [[0, 0] for _ in spec.levels]  # [trials, correct] per level

    @property
    def finished(self) -> bool:
        return self.trial >= len(self.order)

    @property
    def level(self) -> float | None:
        return None if self.finished else self.spec.levels[self.order[self.trial]]

    def update(self, correct) -> None:
        if self.finished:
            raise ValueError("the method of constant stimuli has finished: no trial to answer")
        count = self.counts[self.order[self.trial]]
        count[0] += 1
        count[1] += int(bool(correct))
        self.trial += 1

    def estimate(self) -> None:
        return None  # the fit (fit.py) estimates; this method only presents

    def record(self) -> dict:
        return {"trial": self.trial, "level": self.level, "finished": self.finished,
                "counts": [[lv, n, k] for lv, (n, k) in zip(self.spec.levels, self.counts)]}
