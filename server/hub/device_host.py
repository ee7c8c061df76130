"""The hub's handle on the device host process (devices/device_host_process.py).

Adapter only (server/hub/child.py: add_reader, no thread; restart with backoff): it starts the
process, hands its reports to the hub and answers /api/devices with a snapshot request.

It owns the cue channel: one SEQPACKET pair made at start and kept for the server's life. The
device end goes to every device host process, the loop end to every loop process (the
supervisor passes it on), so either side can restart without the other noticing; records sent
while nobody reads wait in the socket (a full one makes the loop resend its cues next tick).
"""

from __future__ import annotations

import os
import pickle
import socket
import subprocess
import sys
from typing import Callable

from devices.feed import CUE_QUIET_MS
from devices.manager import DeviceConfig
from devices.profiles import DeviceProfile
from server.hub.child import ChildProcess
from server import ipc
from server.ipc.records import (FROM_DEVICE_HOST, DeviceProfiles, DeviceStatus, Hello, Record, Snapshot,
                                SnapshotRequest, Stop)

SNAPSHOT_TIMEOUT_S = 2.0


class DeviceHostUnavailable(RuntimeError):
    """The device host process did not answer (starting, restarting or stuck)."""


class DeviceHost(ChildProcess):
    what = "device host process"
    channel = FROM_DEVICE_HOST

    def __init__(self, configs: list[DeviceConfig], *, on_report: Callable[[dict], None],
                 on_profiles: Callable[[dict], None] = lambda profiles: None, cue_quiet_ms: float = CUE_QUIET_MS):
        super().__init__()
        self.configs = list(configs)
        self.cue_quiet_ms = cue_quiet_ms  # the feed turns every actuator off when the loop is quiet this long
        self.on_report = on_report
        self.on_profiles = on_profiles
        self.device_end, self.loop_end = ipc.channel_pair()
        self.info: dict = {}

    def _spawn(self, theirs: socket.socket) -> subprocess.Popen:
        proc = subprocess.Popen(
            [sys.executable, "-m", "devices.device_host_process", "--control-fd", str(theirs.fileno()),
             "--cues-fd", str(self.device_end.fileno()), "--cue-quiet-ms", repr(float(self.cue_quiet_ms))],
            stdin=subprocess.PIPE, pass_fds=(theirs.fileno(), self.device_end.fileno()), cwd=os.getcwd(),
            start_new_session=True)  # Ctrl-C stops the hub, which stops the devices in order (all off first)
        proc.stdin.write(pickle.dumps(self.configs))
        proc.stdin.close()
        return proc

    def _on_record(self, record: Record) -> None:
        match record:
            case DeviceStatus(report):
                self.on_report(report)
            case DeviceProfiles(profiles):
                self.on_profiles({name: DeviceProfile.from_dict(table, where=f"device {name}")
                                  for name, table in profiles.items()})
            case Snapshot(request, snapshot):
                self._answered(request, snapshot)
            case Hello(info):
                self.info = info

    def _closed(self) -> None:
        """The process is gone: a snapshot it was asked for will never come; say so now, not
        after SNAPSHOT_TIMEOUT_S (the console polls /api/devices while devices come back)."""
        self._fail_requests(DeviceHostUnavailable("the device host process exited (restarting)"))

    async def snapshot(self, writes: int = 0) -> dict:
        """The devices as the console shows them (DeviceManager.snapshot plus the feed's info)."""
        return await self._ask(lambda request: SnapshotRequest(request, writes), SNAPSHOT_TIMEOUT_S,
                               DeviceHostUnavailable)

    async def stop(self) -> None:
        """Every actuator off, the ports drained and closed, the process gone."""
        await self._stop(Stop(), 5.0)
        self.device_end.close()
        self.loop_end.close()
