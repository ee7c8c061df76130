"""Transformed up-down (Levitt 1971) and weighted up-down (Kaernbach 1991) staircases.

Transformed up-down: `down` correct answers in a row make the task harder by one down step, `up`
wrong answers in a row make it easier by one up step. 1-up/m-down converges where p^m = 1/2
(1-up/2-down: 70.7 %, 1-up/3-down: 79.4 %), n-up/1-down where (1 − p)^n = 1/2 (Levitt 1971,
JASA 49:467). Weighted up-down (1-up/1-down): a correct answer steps down by S↓, a wrong one up
by S↑; the track is at equilibrium where p·S↓ = (1 − p)·S↑, so S↑/S↓ = p/(1 − p) sets the target
p (Kaernbach 1991, P&P 49:227).

A reversal is a move against the direction of the move before it; the reversal's level is the
level of the trial that caused it. The step after k reversals is `steps[k]` (the last repeats).
Moves are clamped to the bounds (counted). The estimate is the mean position u (scales.py) of the
last `average` reversals.
"""

from __future__ import annotations

from dataclasses import dataclass

from server.psychophysics.scales import SCALES, Scale
from server.psychophysics.spec import Fields

KINDS = ("up-down", "weighted-up-down")


@dataclass(frozen=True)
class StaircaseSpec:
    kind: str
    start: float
    scale: Scale
    down: int                   # correct in a row → one step harder
    up: int                     # wrong in a row → one step easier
    steps_down: tuple           # by reversal count, in the scale's step units
    steps_up: tuple
    low: float                  # bounds, in u
    high: float
    max_trials: int | None
    max_reversals: int | None
    average: int                # reversals averaged by the estimate
    harder: int                 # −1: a lower level is harder (intensity); +1: a higher one
    target: float | None        # the probability the track converges to, when it is defined

    @classmethod
    def parse(cls, table, where: str = "procedure") -> "StaircaseSpec":
        f = Fields(table, where)
        kind = f.choice("kind", KINDS)
        scale_kind = f.choice("scale", SCALES, "linear")
        ladder = f.numbers("levels", None, min_len=2) if scale_kind == "ladder" else None
        if scale_kind == "ladder":
            if ladder is None:
                raise f.error("levels", "a ladder scale needs its levels (a list of at least 2 numbers)")
            if any(b <= a for a, b in zip(ladder, ladder[1:])):
                raise f.error("levels", f"the ladder must increase strictly, got {list(ladder)}")
        scale = Scale(scale_kind, ladder or ())
        positive = scale_kind in ("log", "db")
        start = f.number("start", ladder[len(ladder) // 2] if ladder else _REQUIRED_START)
        if start is _REQUIRED_START:
            raise f.error("start", "missing (required)")
        if ladder and start not in ladder:
            raise f.error("start", f"must be one of the ladder's levels {list(ladder)}, got {start!r}")
        if positive and start <= 0:
            raise f.error("start", f"a {scale_kind} scale needs a level > 0, got {start!r}")
        guess = f.number("guess", 0.0, low=0.0, high=1.0)
        if guess >= 1:
            raise f.error("guess", "must be < 1")
        harder = f.choice("harder", ("lower", "higher"), "lower")
        steps = f.numbers("steps", positive=True)
        if scale_kind == "log" and any(s <= 1 for s in steps):
            raise f.error("steps", f"a log scale steps by factors > 1, got {list(steps)}")
        if scale_kind == "ladder" and any(s != int(s) for s in steps):
            raise f.error("steps", f"a ladder steps by whole rungs, got {list(steps)}")
        if kind == "up-down":
            down = int(f.number("down", 2, low=1, whole=True))
            up = int(f.number("up", 1, low=1, whole=True))
            steps_up = f.numbers("up_steps", steps, positive=True)
            target = 0.5 ** (1.0 / down) if up == 1 else (1.0 - 0.5 ** (1.0 / up) if down == 1 else None)
            if target is not None and target <= guess:
                raise f.error("down" if up == 1 else "up",
                              f"a {up}-up/{down}-down track converges to p = {target:.3f}, not above the "
                              f"guess rate {guess}: it cannot converge")
        else:
            up = down = 1
            target = f.number("target")
            if not guess < target < 1:
                raise f.error("target", f"must lie in (guess, 1) = ({guess}, 1) for the track to converge, "
                                        f"got {target!r}")
            ratio = target / (1.0 - target)
            steps_up = tuple(s * ratio for s in steps) if scale_kind != "log" else tuple(s ** ratio for s in steps)
        if scale_kind == "log" and any(s <= 1 for s in steps_up):
            raise f.error("up_steps", f"a log scale steps by factors > 1, got {list(steps_up)}")
        if scale_kind == "ladder" and any(s != int(s) for s in steps_up):
            raise f.error("up_steps", f"a ladder steps by whole rungs, got {list(steps_up)}"
                          + (" (weighted: choose steps and target so that steps × target/(1 − target) is whole)"
                             if kind == "weighted-up-down" else ""))
        if ladder:
            low, high = 0.0, float(len(ladder) - 1)
            for name in ("min", "max"):
                if name in f.table:
                    raise f.error(name, "a ladder's bounds are its ends")
        else:
            lo = f.number("min", None, low=0.0, low_open=True) if positive else f.number("min", None)
            hi = f.number("max", None)
            if lo is not None and hi is not None and lo >= hi:
                raise f.error("max", f"the bounds are reversed or empty: min {lo} ≥ max {hi}")
            if (lo is not None and start < lo) or (hi is not None and start > hi):
                raise f.error("start", f"{start} lies outside the bounds [{lo}, {hi}]")
            low = scale.to_u(lo) if lo is not None else float("-inf")
            high = scale.to_u(hi) if hi is not None else float("inf")
        max_trials = f.number("max_trials", None, low=1, whole=True)
        max_reversals = f.number("max_reversals", None, low=1, whole=True)
        if max_trials is None and max_reversals is None:
            raise f.error("max_trials", "a staircase needs a stop: max_trials, max_reversals or both")
        average = int(f.number("average", 6, low=1, whole=True))
        f.done()
        return cls(kind, float(start), scale, down, up, steps, steps_up, low, high, max_trials, max_reversals,
                   average, -1 if harder == "lower" else 1, target)


_REQUIRED_START = object()


class Staircase:
    """The running track. `level` is the next stimulus (None once finished); `update(correct)`
    takes the answer to it; `record()` is the state after the last trial as plain data."""

    def __init__(self, spec: StaircaseSpec, seed=0):
        self.spec = spec
        self.u = spec.scale.to_u(spec.start)
        self.trial = 0
        self.correct_run = self.wrong_run = 0
        self.direction = 0           # the last move's sign in u (0: none yet)
        self.reversals: list[float] = []  # u at each reversal
        self.clamped = 0

    @property
    def finished(self) -> bool:
        s = self.spec
        return ((s.max_trials is not None and self.trial >= s.max_trials)
                or (s.max_reversals is not None and len(self.reversals) >= s.max_reversals))

    @property
    def level(self) -> float | None:
        return None if self.finished else self.spec.scale.to_level(self.u)

    def update(self, correct) -> None:
        if self.finished:
            raise ValueError("the staircase has finished: no trial to answer")
        s = self.spec
        self.trial += 1
        move = 0
        if correct:
            self.correct_run, self.wrong_run = self.correct_run + 1, 0
            if self.correct_run >= s.down:
                self.correct_run, move = 0, s.harder
        else:
            self.wrong_run, self.correct_run = self.wrong_run + 1, 0
            if self.wrong_run >= s.up:
                self.wrong_run, move = 0, -s.harder
        if not move:
            return
        if self.direction and move != self.direction:
            self.reversals.append(self.u)
        self.direction = move
        k = len(self.reversals)
        steps = s.steps_down if move == s.harder else s.steps_up
        target = self.u + move * s.scale.step_u(steps[min(k, len(steps) - 1)])
        clamped = min(max(target, s.low), s.high)
        if clamped != target:
            self.clamped += 1
        self.u = clamped

    def estimate(self) -> float | None:
        """The mean of the last `average` reversals (in u), as a level; None before any reversal."""
        if not self.reversals:
            return None
        last = self.reversals[-self.spec.average:]
        return self.spec.scale.to_level(sum(last) / len(last))

    def record(self) -> dict:
        to_level = self.spec.scale.to_level
        return {"trial": self.trial, "level": self.level, "correct_run": self.correct_run,
                "wrong_run": self.wrong_run, "direction": self.direction,
                "reversals": [to_level(u) for u in self.reversals], "clamped": self.clamped,
                "finished": self.finished, "estimate": self.estimate()}
