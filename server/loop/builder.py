"""Builds the loop's scenario switches on a thread of their own, off the tick.

Building a scenario takes milliseconds (8-17 ms for the positioning tasks' scenes), several tick
periods, so the tick never does it (server/loop/tick.py, "A scenario switch is built outside the
tick"). The loop process calls `between_ticks()` after every tick: it installs a finished build
(cheap: the core takes the new simulation over and announces it) and starts building the core's
pending switch, if any, on a new thread.

That thread must not delay the tick. It inherits the tick thread's SCHED_FIFO priority and CPU;
at equal FIFO priority the woken tick thread would wait for it to block, so it first drops to the
lowest real-time priority (or stays at normal priority when the loop has none) on the same CPU:
the tick thread preempts it the moment it wakes, and while a tick runs the builder does not run at
all. Measured against the other arrangement, normal priority on the other CPU: there the builder
holding the GIL was preempted by other processes while the tick thread waited for that GIL, and
ticks took up to 110 ms. What remains is the GIL hand-over: while a build runs the switch interval
is cut from 5 ms to BUILD_SWITCH_INTERVAL_S, so a waking tick thread gets the GIL within about
that long. One build at a time; a switch superseded during its build is discarded when it ends,
and the latest one is built next.
"""

from __future__ import annotations

import gc
import importlib
import os
import sys
import threading
import traceback

from server.ipc.records import Log
from server.loop.tick import Loop, Switch
from server.loop.simulation import Simulation

BUILD_SWITCH_INTERVAL_S = 0.0001
# Imported by the builder right after start, off the tick: the loop starts without them (a
# restart is ~0.4 s sooner) and the first switch to a mesh scene does not pay for them.
WARM_UP_MODULES = ("trimesh",)


def _step_aside() -> None:
    """This thread only: below the tick thread (on Linux the call acts on the calling thread)."""
    try:
        if os.sched_getscheduler(0) == os.SCHED_FIFO:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(os.sched_get_priority_min(os.SCHED_FIFO)))
    except (PermissionError, OSError, AttributeError):
        pass  # the loop runs at normal priority: so does its builder


class SwitchBuilder:
    def __init__(self, core: Loop):
        self.core = core
        self.builds = 0
        self._thread: threading.Thread | None = None
        # set by the thread (one store); switch None: the warm-up ended
        self._done: tuple[Switch | None, Simulation | None, str | None] | None = None
        self._interval = sys.getswitchinterval()
        self._warm_up: tuple[str, ...] = ()

    def warm_up(self, modules: tuple[str, ...] = WARM_UP_MODULES) -> None:
        """Import `modules` on the builder's thread before any build (the next between_ticks)."""
        self._warm_up = tuple(modules)

    @property
    def building(self) -> bool:
        return self._thread is not None

    @property
    def busy(self) -> bool:
        """A thread is running, or a warm-up waits to start: call between_ticks after each tick."""
        return self._thread is not None or bool(self._warm_up)

    def between_ticks(self) -> None:
        """Install a finished build; start building the pending switch. Call from the tick's thread."""
        done = self._done
        if done is not None:
            self._done = None
            self._thread.join()  # it has stored its result: it is ending
            self._thread = None
            sys.setswitchinterval(self._interval)
            switch, sim, error = done
            if switch is None:  # the warm-up
                # what it imported lives for the whole run: out of the collector's sight, as the
                # start-up's objects are (process.py), or a full collection in some later tick
                # walks the mesh library's thousands of objects (a 12 ms tick, measured)
                gc.freeze()
                if error:
                    self.core.outbox.append(Log("warning", f"loop warm-up import failed: {error}"))
            elif sim is not None:
                self.core.install(switch, sim)  # False: superseded meanwhile; the latest is built next
            else:
                self.core.abandon(switch, error or "build failed")
        if self._warm_up and self._thread is None:
            modules, self._warm_up = self._warm_up, ()
            sys.setswitchinterval(BUILD_SWITCH_INTERVAL_S)
            self._thread = threading.Thread(target=self._import, args=(modules,), name="loop-warm-up", daemon=True)
            self._thread.start()
            return
        switch = self.core.pending_switch
        if switch is not None and self._thread is None:
            sys.setswitchinterval(BUILD_SWITCH_INTERVAL_S)
            self._thread = threading.Thread(target=self._build, args=(switch,), name="scenario-builder",
                                            daemon=True)
            self._thread.start()

    def _import(self, modules: tuple[str, ...]) -> None:
        _step_aside()
        error = None
        for name in modules:
            try:
                importlib.import_module(name)
            except Exception:  # noqa: BLE001 - a missing optional module is reported, not fatal
                error = traceback.format_exc(limit=1)
        self._done = (None, None, error)

    def _build(self, switch: Switch) -> None:
        _step_aside()
        try:
            result = (switch, self.core.build(switch), None)
        except Exception:  # noqa: BLE001 - a bad switch is reported, the loop goes on
            result = (switch, None, traceback.format_exc())
        self.builds += 1
        self._done = result
