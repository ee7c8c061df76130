"""Starts the loop process, carries records to and from it, restarts it if it dies.

Adapter only: records from the loop are handed to a callback on the asyncio loop (add_reader,
no thread); records to the loop are sent without blocking. A dead loop process is logged and
restarted with backoff, so a crash in a scenario cannot take the server down silently.
Every loop process also gets the loop end of the cue channel (to the device host process,
server/hub/device_host.py), so device commands never pass this event loop, and the tracker UDP
socket (server/loop/tracker_udp.py); both are made once and kept across loop restarts.
"""

from __future__ import annotations

import asyncio
import logging
import os
import socket
import subprocess
import sys
from typing import Callable

from server.loop import ipc
from server.loop.process import LoopConfig

log = logging.getLogger("viestac.loop")


class LoopSupervisor:
    def __init__(self, config: LoopConfig, on_record: Callable[[list], None]):
        self.config = config
        self.on_record = on_record
        # Sockets owned elsewhere and passed to every loop process:
        self.cue_sock: socket.socket | None = None      # the loop end of the cue channel (device host)
        self.tracker_sock: socket.socket | None = None  # the tracker UDP port
        self.proc: subprocess.Popen | None = None
        self.restarts = 0
        self.dropped_to_loop = 0
        self._sock = None
        self._doorbell: ipc.Doorbell | None = None
        self._watch: asyncio.Task | None = None
        self._closing = False

    @property
    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def start(self) -> None:
        loop = asyncio.get_running_loop()
        ours, theirs = ipc.channel_pair()
        self._doorbell = ipc.Doorbell()
        args = ["--fd", str(theirs.fileno()), "--doorbell", str(self._doorbell.fd)]
        passed = [theirs.fileno(), self._doorbell.fd]
        for option, shared in (("--cues-fd", self.cue_sock), ("--tracker-fd", self.tracker_sock)):
            if shared is not None:  # ours to keep: a restarted loop gets the same one
                args += [option, str(shared.fileno())]
                passed.append(shared.fileno())
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "server.loop.process", *args, "--config", self.config.to_json()],
            pass_fds=tuple(passed), cwd=os.getcwd(),
            start_new_session=True)  # Ctrl-C in a terminal stops the hub, which stops the loop in order
        theirs.close()
        self._sock = ours
        loop.add_reader(ours.fileno(), self._readable)
        if self._watch is None:
            self._watch = asyncio.create_task(self._watchdog())

    def _readable(self) -> None:
        try:
            records = ipc.drain(self._sock)
        except ipc.PeerClosed:
            asyncio.get_running_loop().remove_reader(self._sock.fileno())
            return
        for record in records:
            try:
                self.on_record(record)
            except Exception:  # noqa: BLE001 - one bad record must not stop the reader
                log.exception("failed to handle a loop record of kind %r", record[0] if record else None)

    def send(self, record: list) -> bool:
        if self._sock is None:
            return False
        try:
            ok = ipc.send_record(self._sock, record)
        except OSError:  # the loop process is gone; the watchdog restarts it
            ok = False
        if ok:
            self._doorbell.ring()  # after the send: when the loop sees the bell, the record is there
        else:
            self.dropped_to_loop += 1
        return ok

    async def _watchdog(self) -> None:
        backoff = 0.5
        while not self._closing:
            await asyncio.sleep(0.2)
            if self.proc is not None and self.proc.poll() is not None and not self._closing:
                log.error("loop process exited with code %s; restarting in %.1f s", self.proc.returncode, backoff)
                self._close_socket()
                await asyncio.sleep(backoff)
                backoff = min(backoff * 2, 10.0)
                self.restarts += 1
                self.start()

    def _close_socket(self) -> None:
        if self._sock is not None:
            try:
                asyncio.get_running_loop().remove_reader(self._sock.fileno())
            except (ValueError, RuntimeError):
                pass
            self._sock.close()
            self._sock = None
        if self._doorbell is not None:
            self._doorbell.close()
            self._doorbell = None

    async def stop(self) -> None:
        self._closing = True
        if self._watch:
            self._watch.cancel()
        if self._sock is not None:
            self.send(["stop"])
        if self.proc is not None:
            try:
                await asyncio.wait_for(asyncio.to_thread(self.proc.wait), 2.0)
            except asyncio.TimeoutError:
                self.proc.kill()
        self._close_socket()
