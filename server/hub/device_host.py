"""The hub's handle on the device host process (devices/host_process.py).

Adapter only, on the asyncio loop like the loop supervisor: it starts the process, reads its
control records with add_reader (no thread), hands reports to the hub, answers /api/devices with
a snapshot request, and restarts the process with backoff if it dies.

It owns the cue channel: one SEQPACKET pair made at start and kept for the server's life. The
device end goes to every device host process, the loop end to every loop process (the
supervisor passes it on), so either side can restart without the other noticing; records sent
while nobody reads wait in the socket (a full one makes the loop resend its cues next tick).
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import os
import pickle
import subprocess
import sys
from typing import Callable


from devices.manager import DeviceConfig
from devices.profiles import DeviceProfile
from server.loop import ipc

log = logging.getLogger("viestac.devices")

SNAPSHOT_TIMEOUT_S = 2.0


class DeviceHostUnavailable(RuntimeError):
    """The device host process did not answer (starting, restarting or stuck)."""


class DeviceHost:
    def __init__(self, configs: list[DeviceConfig], *, on_report: Callable[[dict], None],
                 on_profiles: Callable[[dict], None] = lambda profiles: None):
        self.configs = list(configs)
        self.on_report = on_report
        self.on_profiles = on_profiles
        self.device_end, self.loop_end = ipc.channel_pair()
        self.proc: subprocess.Popen | None = None
        self.info: dict = {}
        self.restarts = 0
        self._control = None
        self._requests: dict[int, asyncio.Future] = {}
        self._ids = itertools.count(1)
        self._watch: asyncio.Task | None = None
        self._closing = False

    @property
    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def start(self) -> None:
        ours, theirs = ipc.channel_pair()
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "devices.host_process", "--control-fd", str(theirs.fileno()),
             "--cues-fd", str(self.device_end.fileno())],
            stdin=subprocess.PIPE, pass_fds=(theirs.fileno(), self.device_end.fileno()), cwd=os.getcwd(),
            start_new_session=True)  # Ctrl-C stops the hub, which stops the devices in order (all off first)
        theirs.close()
        self.proc.stdin.write(pickle.dumps(self.configs))
        self.proc.stdin.close()
        self._control = ours
        asyncio.get_running_loop().add_reader(ours.fileno(), self._readable)
        if self._watch is None:
            self._watch = asyncio.create_task(self._watchdog())

    def _readable(self) -> None:
        try:
            records = ipc.drain(self._control)
        except ipc.PeerClosed:
            asyncio.get_running_loop().remove_reader(self._control.fileno())
            return
        for record in records:
            try:
                self._on_record(record)
            except Exception:  # noqa: BLE001 - one bad record must not stop the reader
                log.exception("failed to handle a device host record of kind %r", record[0] if record else None)

    def _on_record(self, record: list) -> None:
        kind = record[0]
        if kind == "report":
            self.on_report(record[1])
        elif kind == "profiles":
            self.on_profiles({name: DeviceProfile.from_dict(table, where=f"device {name}")
                              for name, table in record[1].items()})
        elif kind == "snapshot":
            future = self._requests.pop(record[1], None)
            if future is not None and not future.done():
                future.set_result(record[2])
        elif kind == "hello":
            self.info = record[1]

    def _send(self, record: list) -> bool:
        if self._control is None:
            return False
        try:
            return ipc.send_record(self._control, record)
        except OSError:
            return False

    async def snapshot(self, writes: int = 0) -> dict:
        """The devices as the console shows them (DeviceManager.snapshot plus the feed's info)."""
        request = next(self._ids)
        future = asyncio.get_running_loop().create_future()
        self._requests[request] = future
        if not self._send(["snapshot", request, writes]):
            self._requests.pop(request, None)
            raise DeviceHostUnavailable("the device host process is not running (restarting?)")
        try:
            return await asyncio.wait_for(future, SNAPSHOT_TIMEOUT_S)
        except asyncio.TimeoutError:
            raise DeviceHostUnavailable(f"the device host process did not answer within {SNAPSHOT_TIMEOUT_S:g} s") from None
        finally:
            self._requests.pop(request, None)

    def submit(self, cues: list[dict]) -> bool:
        """Cues (wire form) from the hub itself, e.g. everything off; the loop's go by the feed."""
        return self._send(["submit", cues])

    async def _watchdog(self) -> None:
        backoff = 0.5
        while not self._closing:
            await asyncio.sleep(0.2)
            if self.proc is not None and self.proc.poll() is not None and not self._closing:
                log.error("device host process exited with code %s; restarting in %.1f s", self.proc.returncode, backoff)
                self._close_control()
                await asyncio.sleep(backoff)
                backoff = min(backoff * 2, 10.0)
                self.restarts += 1
                self.start()

    def _close_control(self) -> None:
        if self._control is not None:
            try:
                asyncio.get_running_loop().remove_reader(self._control.fileno())
            except (ValueError, RuntimeError):
                pass
            self._control.close()
            self._control = None

    async def stop(self) -> None:
        """Every actuator off, the ports drained and closed, the process gone."""
        self._closing = True
        if self._watch:
            self._watch.cancel()
        self._send(["stop"])
        if self.proc is not None:
            try:
                await asyncio.wait_for(asyncio.to_thread(self.proc.wait), 5.0)
            except asyncio.TimeoutError:
                self.proc.kill()
        self._close_control()
        self.device_end.close()
        self.loop_end.close()
