"""Starts the loop process, carries records to and from it, restarts it if it dies.

Adapter only (server/hub/child.py: add_reader, no thread; restart with backoff), so a crash in a
scenario cannot take the server down silently. Records to the loop are sent without blocking and
followed by a ring of the mailbox doorbell, from the event loop's thread only (server/hub/owner.py:
the ring is an unlocked read-modify-write, and a restart replaces the doorbell). Every loop
process also gets the loop end of the cue channel (to the device host process,
server/hub/device_host.py), so device commands never pass this event loop, and the tracker UDP
socket (server/loop/tracker_udp.py); both are made once and kept across loop restarts.

A restarted loop continues the clock: it starts at the tick the dead one would have reached (the
last tick seen here plus the time since then on this process's monotonic clock), so ticks, the
simulation time and frame numbers never go back (the recorder and the clients rely on it). It
resumes the scenario that ran, read from its one owner when the loop is started (`resume`: the
hub's ScenarioControl, server/hub/control.py), and a free trial, but never a recorded trial: the
experiment ends that attempt as interrupted (docs/data.md "A loop restart during a trial").
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from dataclasses import replace
from typing import Callable

from server.hub.child import ChildProcess
from server import ipc
from server.ipc.records import FROM_LOOP, Record, State, Stop
from server.loop.process import LoopConfig


class LoopSupervisor(ChildProcess):
    what = "loop process"
    channel = FROM_LOOP

    def __init__(self, config: LoopConfig, on_record: Callable[[Record], None],
                 resume: Callable[[], dict | None] = lambda: None):
        """`config`: what the first loop runs. `resume()`: what a loop started now runs instead,
        {"id", "params", "seed", "trial"} as the running loop announced it (the trial None when it
        must not be resumed), or None (nothing announced yet: `config`'s)."""
        super().__init__()
        self.config = config
        self.resume = resume
        self.on_record = on_record
        # Sockets owned elsewhere and passed to every loop process:
        self.cue_sock: socket.socket | None = None      # the loop end of the cue channel (device host)
        self.tracker_sock: socket.socket | None = None  # the tracker UDP port
        self.dropped_to_loop = 0
        self._doorbell: ipc.Doorbell | None = None
        self._last: tuple[int, int, float] | None = None  # (tick, frame, monotonic s) of the last state record

    def continue_from(self, now_s: float) -> tuple[int, int]:
        """(tick, frame) a loop started now begins at: past every tick and frame the last one reached."""
        if self._last is None:
            return self.config.start_tick, self.config.start_frame
        tick, frame, seen_s = self._last
        # The dead loop ran at most one tick per period after its last state record (it resyncs
        # after a stall, never bursts), so this is past its last tick.
        return tick + 1 + int(max(0.0, now_s - seen_s) * self.config.tick_hz), frame + 1

    def _spawn(self, theirs: socket.socket) -> subprocess.Popen:
        start_tick, start_frame = self.continue_from(time.monotonic())
        config = replace(self.config, start_tick=start_tick, start_frame=start_frame)
        state = self.resume()
        if state is not None:  # a restarted loop comes back with what ran, not with the start-up scenario
            config = replace(config, scenario=state["id"], scenario_params=state["params"], seed=state["seed"],
                             trial=state["trial"])
        self._doorbell = ipc.Doorbell()
        args = ["--fd", str(theirs.fileno()), "--doorbell", str(self._doorbell.fd)]
        passed = [theirs.fileno(), self._doorbell.fd]
        for option, shared in (("--cues-fd", self.cue_sock), ("--tracker-fd", self.tracker_sock)):
            if shared is not None:  # ours to keep: a restarted loop gets the same one
                args += [option, str(shared.fileno())]
                passed.append(shared.fileno())
        return subprocess.Popen(
            [sys.executable, "-m", "server.loop.process", *args, "--config", config.to_json()],
            pass_fds=tuple(passed), cwd=os.getcwd(),
            start_new_session=True)  # Ctrl-C in a terminal stops the hub, which stops the loop in order

    def _on_record(self, record: Record) -> None:
        if type(record) is State:
            self._last = (record.tick, record.frame, time.monotonic())
        self.on_record(record)

    def _closed(self) -> None:
        if self._doorbell is not None:
            self._doorbell.close()
            self._doorbell = None

    def _send(self, record: Record) -> bool:
        """Every record to the loop, the stop included, rings the doorbell once: the loop reads
        as many records as it was rung for (server/ipc/__init__.py), so an unrung one is never read."""
        ok = super()._send(record)
        if ok and self._doorbell is not None:
            self._doorbell.ring()  # after the send: when the loop sees the bell, the record is there
        return ok

    def send(self, record: Record) -> bool:
        ok = self._send(record)
        if not ok:
            self.dropped_to_loop += 1
        return ok

    async def stop(self) -> None:
        await self._stop(Stop(), 2.0)
