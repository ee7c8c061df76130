"""`viestac serve --loop-cpu` on the running server: where every thread of every server process
may run (server/cpu_plan.py), read from the kernel, also for a loop restarted after a kill."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import pytest

from tests.live_server import get_json, start_server, stop_server
from server.cpu_plan import plan_cpus

pytestmark = pytest.mark.skipif(len(os.sched_getaffinity(0)) < 2, reason="one CPU: nothing to plan")


def _tree(pid: int) -> list[int]:
    """`pid` and all its descendants."""
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        for task in Path(f"/proc/{p}/task").iterdir():
            todo += [int(c) for c in (task / "children").read_text().split()]
    return out


def _thread_cpus(pid: int) -> set[frozenset[int]]:
    """The CPU set of each of the process's threads."""
    return {frozenset(os.sched_getaffinity(int(tid.name))) for tid in Path(f"/proc/{pid}/task").iterdir()}


def _health_until(base: str, done, timeout_s: float = 20.0) -> dict:
    deadline = time.monotonic() + timeout_s
    while True:
        health = get_json(base + "/api/health")
        if done(health):
            return health
        assert time.monotonic() < deadline, health["loop"]
        time.sleep(0.1)


def test_own_keeps_every_other_server_thread_off_the_loops_cpu_and_a_restarted_loop_keeps_it():
    expected = plan_cpus(os.sched_getaffinity(0), "own")
    proc, base = start_server("contact-angle", ["--loop-cpu", "own"])
    try:
        health = _health_until(base, lambda h: h["loop"]["pid"] is not None)
        assert health["loop"]["cpus"] == expected.to_dict()
        assert health["loop"]["cpu"] == expected.loop
        for restarted in (False, True):
            loop_pid = health["loop"]["pid"]
            others = [pid for pid in _tree(proc.pid) if pid != loop_pid]
            assert len(others) >= 4, "hub, device host and the simulated rig's two emulators"
            assert _thread_cpus(loop_pid) == {frozenset({expected.loop})}, f"restarted={restarted}"
            for pid in others:
                assert _thread_cpus(pid) == {expected.others}, Path(f"/proc/{pid}/cmdline").read_text()
            if not restarted:
                os.kill(loop_pid, signal.SIGKILL)
                health = _health_until(base, lambda h, dead=loop_pid: h["loop"]["pid"] not in (None, dead)
                                       and h["loop"]["cpu"] is not None)
    finally:
        stop_server(proc)


def test_shared_pins_only_the_loop():
    expected = plan_cpus(os.sched_getaffinity(0), "shared")
    proc, base = start_server("contact-angle", ["--loop-cpu", "shared"])
    try:
        health = _health_until(base, lambda h: h["loop"]["pid"] is not None)
        assert health["loop"]["cpus"]["own"] is False and health["loop"]["cpu"] == expected.loop
        assert _thread_cpus(health["loop"]["pid"]) == {frozenset({expected.loop})}
        assert _thread_cpus(proc.pid) == {frozenset(os.sched_getaffinity(0))}
    finally:
        stop_server(proc)
