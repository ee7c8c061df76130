"""Real-time priority for the threads on the tracker → device path, best effort.

On a 2-core machine with many viewers both cores are busy right when a cue changes (the hub
sends the frame of that tick to every viewer); a normal-priority thread woken then waited for a
CPU for up to ~2 ms (docs/performance.md "Tracker → device latency"). Threads that only sleep
and hand data on ask for SCHED_FIFO below the loop process's 50, so they never delay a tick.
Without root or CAP_SYS_NICE they keep normal priority; `/api/devices` and the bench report it.
"""

from __future__ import annotations

import os

DEVICE_THREAD_PRIORITY = 10  # below the loop process (50)


def fifo_this_thread(priority: int = DEVICE_THREAD_PRIORITY) -> bool:
    """Switch the calling thread (Linux: pid 0 is the thread) to SCHED_FIFO; False if not allowed."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
        return True
    except (PermissionError, OSError, AttributeError):
        return False
