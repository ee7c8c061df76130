"""A supervised child process (server/hub/child.py): restarted at once after a first death, with a
wait only for repeated crashes, the wait reset after HEALTHY_S up; death seen when its socket
closes; on_exit/on_start called."""

from __future__ import annotations

import asyncio
import os
import signal
import subprocess
import sys
import time

from server.hub import child
from server.hub.child import ChildProcess, RestartBackoff
from server.ipc.records import FROM_DEVICE_HOST, Stop


def test_backoff_first_death_is_immediate_repeats_double_and_a_healthy_run_resets():
    b = RestartBackoff(healthy_s=10.0, first_s=0.5, max_s=4.0)
    b.started(0.0)
    assert b.died(1.0) == 0.0, "the first death restarts at once"
    b.started(1.0)
    assert b.died(1.5) == 0.5
    b.started(2.0)
    assert b.died(2.1) == 1.0
    b.started(3.1)
    assert b.died(3.2) == 2.0
    b.started(5.2)
    assert b.died(5.3) == 4.0
    b.started(9.3)
    assert b.died(9.4) == 4.0, "capped"
    b.started(13.4)
    assert b.died(23.5) == 0.0, "up HEALTHY_S: a first death again"
    b.started(23.4)
    assert b.died(24.0) == 0.5


class Sleeper(ChildProcess):
    """A child that only holds its end of the socket."""
    what = "test child"
    channel = FROM_DEVICE_HOST  # it sends nothing

    def _spawn(self, theirs):
        return subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"], pass_fds=(theirs.fileno(),))

    def _on_record(self, record):
        pass


def test_a_killed_child_is_restarted_at_once_and_the_hooks_are_called(monkeypatch):
    monkeypatch.setattr(child, "POLL_S", 30.0)  # the poll cannot be what sees it: the socket closing must

    async def go():
        c = Sleeper()
        events = []
        c.on_start = lambda what: events.append(("start", what, time.monotonic()))
        c.on_exit = lambda what, code: events.append(("exit", code, time.monotonic()))
        c.start()
        await asyncio.sleep(0.2)
        try:
            for n in (1, 2):
                pid = c.proc.pid
                killed = time.monotonic()
                os.kill(pid, signal.SIGKILL)
                deadline = time.monotonic() + 5.0
                while c.restarts < n:
                    assert time.monotonic() < deadline, "not restarted"
                    await asyncio.sleep(0.005)
                assert c.proc.pid != pid and c.alive
                exit_event, start_event = events[-2:]
                assert exit_event[:2] == ("exit", -signal.SIGKILL) and start_event[:2] == ("start", "test child")
                if n == 1:
                    assert start_event[2] - killed < 0.5 * child.BACKOFF_FIRST_S, "first death: no backoff"
                else:
                    assert start_event[2] - killed >= child.BACKOFF_FIRST_S, "a second death in a row waits"
        finally:
            await c._stop(Stop(), 0.1)
        assert not c.alive

    asyncio.run(go())
