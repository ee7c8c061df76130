"""The scale a staircase steps on: where a level sits (its position u) and back.

| scale    | position u of level x | a step of s moves u by | bounds and start |
|----------|-----------------------|------------------------|------------------|
| linear   | x                     | s (level units)        | level units      |
| log      | ln x                  | ln s (s: a factor > 1) | level units, > 0 |
| db       | 20·log10 x            | s dB                   | level units, > 0 |
| ladder   | index into `levels`   | s whole index steps    | the ladder's ends|

The staircase counts, clamps and averages in u, so a dB staircase's estimate is the mean of its
reversal levels in dB (the geometric mean of the amplitudes) and a ladder's the mean of the
ladder indices at the reversals, read back as a level by linear interpolation between rungs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

SCALES = ("linear", "log", "db", "ladder")


@dataclass(frozen=True)
class Scale:
    kind: str
    ladder: tuple[float, ...] = ()

    def to_u(self, level: float) -> float:
        if self.kind == "linear":
            return float(level)
        if self.kind == "log":
            return math.log(level)
        if self.kind == "db":
            return 20.0 * math.log10(level)
        return float(self.ladder.index(level))

    def to_level(self, u: float) -> float:
        if self.kind == "linear":
            return u
        if self.kind == "log":
            return math.exp(u)
        if self.kind == "db":
            return 10.0 ** (u / 20.0)
        low = int(math.floor(u))
        if low >= len(self.ladder) - 1:
            return self.ladder[-1]
        return self.ladder[low] + (u - low) * (self.ladder[low + 1] - self.ladder[low])

    def step_u(self, step: float) -> float:
        """A step as the spec gives it (level units, a factor, dB, rungs) → a move of u."""
        return math.log(step) if self.kind == "log" else float(step)
