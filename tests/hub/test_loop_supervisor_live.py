"""The hub's loop supervisor against a real loop process: every record it sends rings the
mailbox's doorbell (the loop reads only what it was rung for), so a stop is read and the loop
exits on its own; a loop killed with records it never read is seen dead and started again
without an error in the hub's event loop."""

from __future__ import annotations

import asyncio
import os
import signal
import time

from server.hub.supervisor import LoopSupervisor
from server.loop.process import LoopConfig
from server.ipc.records import Input
from tests.ipc import sent


async def _until(done, timeout_s: float = 20.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not done():
        assert time.monotonic() < deadline, "timed out"
        await asyncio.sleep(0.01)


def test_a_stopped_loop_reads_the_stop_and_exits_by_itself():
    async def go():
        records: list[list] = []
        supervisor = LoopSupervisor(LoopConfig(realtime=False), records.append)
        supervisor.start()
        await _until(lambda: any(r[0] == "state" for r in map(sent, records)))
        await supervisor.stop()
        return supervisor.proc.returncode

    assert asyncio.run(go()) == 0  # not -9: the supervisor kills a loop that ignores the stop after 2 s


def test_a_loop_killed_with_records_unread_is_restarted_without_an_error_in_the_event_loop():
    async def go():
        errors: list[dict] = []
        asyncio.get_running_loop().set_exception_handler(lambda loop, context: errors.append(context))
        records: list[list] = []
        supervisor = LoopSupervisor(LoopConfig(realtime=False), records.append)
        supervisor.start()
        try:
            await _until(lambda: any(r[0] == "state" for r in map(sent, records)))
            first = supervisor.proc.pid
            os.kill(first, signal.SIGSTOP)  # it reads nothing more ...
            for _ in range(20):
                assert supervisor.send(Input(1, "space", "press"))
            os.kill(first, signal.SIGKILL)  # ... and dies with our records in its end of the socket
            await _until(lambda: supervisor.proc.pid != first and any(
                r[0] == "hello" and r[1]["pid"] == supervisor.proc.pid for r in map(sent, records)))
        finally:
            await supervisor.stop()
        return errors

    assert asyncio.run(go()) == []
