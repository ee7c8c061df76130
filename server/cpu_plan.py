"""Which CPUs the server's processes run on (`viestac serve --loop-cpu`).

The 1 kHz loop pins itself to one CPU so its caches are the ones it left a tick ago. Whether the
other server processes (the hub, the device host, the tracker host, the simulated rig) may also
run there is the choice made here:

- `shared`: they may. On a 2-CPU machine the hub's broadcasting then runs on the loop's CPU
  between ticks, and a tick that follows finds colder caches (docs/performance.md "The loop's
  CPU to itself").
- `own`: they keep off it, so the loop's CPU runs only the loop (and whatever else the machine
  runs). The hub is one Python thread, so on 2 CPUs it loses no parallelism, but it now shares
  one CPU with the device host and anything else the machine runs.
- `auto`: `own` when at least `OWN_FROM_CPUS` CPUs are usable (the others still have two or
  more), `shared` below that.

Pure: `plan_cpus` takes the usable CPUs (`os.sched_getaffinity(0)` in the shell) and returns the
plan. Two calls change the calling process: `keep_off_loop_cpu` (the server, by the plan) and
`pin_process` (the loop on its CPU; the bench's load generator off it).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Iterable

MODES = ("auto", "shared", "own")
OWN_FROM_CPUS = 4


@dataclass(frozen=True)
class CpuPlan:
    mode: str                # the mode asked for
    loop: int | None         # the CPU the loop pins itself to; None: not pinned (a single CPU)
    others: frozenset[int]   # the CPUs every other server process may use

    @property
    def own(self) -> bool:
        return self.loop is not None and self.loop not in self.others

    def to_dict(self) -> dict:
        return {"mode": self.mode, "loop": self.loop, "others": sorted(self.others), "own": self.own}


def check_mode(mode: str) -> str:
    if mode not in MODES:
        raise ValueError(f"loop CPU mode must be one of {', '.join(MODES)}, got {mode!r}")
    return mode


def plan_cpus(usable: Iterable[int], mode: str = "auto") -> CpuPlan:
    """The loop on the highest usable CPU; the others on all of them (`shared`) or on the rest
    (`own`). With one CPU nothing is pinned and `own` cannot hold: it falls back to sharing."""
    check_mode(mode)
    cpus = frozenset(usable)
    if not cpus:
        raise ValueError("no usable CPU")
    if len(cpus) == 1:
        return CpuPlan(mode, None, cpus)
    loop = max(cpus)
    own = mode == "own" or (mode == "auto" and len(cpus) >= OWN_FROM_CPUS)
    return CpuPlan(mode, loop, cpus - {loop} if own else cpus)


def keep_off_loop_cpu(plan: CpuPlan) -> None:
    """The server's own process: on `plan.others` when the loop has its CPU to itself."""
    if plan.own:
        pin_process(plan.others)


def pin_process(cpus: Iterable[int]) -> None:
    """Restrict every thread of this process, and so every thread and child started after, to
    `cpus`; OSError when the kernel refuses (a CPU outside the process's cpuset). Each thread has
    its own CPU set and some start at import (numpy's BLAS workers), so all of them are set."""
    cpus = frozenset(cpus)
    try:
        threads = [int(tid) for tid in os.listdir("/proc/self/task")]
    except OSError:  # no /proc: the calling thread at least
        threads = [0]
    for tid in threads:
        try:
            os.sched_setaffinity(tid, cpus)
        except ProcessLookupError:  # it ended meanwhile
            pass
