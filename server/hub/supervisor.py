"""Starts the loop process, carries records to and from it, restarts it if it dies.

Adapter only: records from the loop are handed to a callback on the asyncio loop (add_reader,
no thread); records to the loop are sent without blocking. A dead loop process is logged and
restarted with backoff, so a crash in a scenario cannot take the server down silently.
Every loop process also gets a cue channel of its own, handed to `on_cue_channel` (the device
feed thread, server/hub/device_feed.py), so device commands do not wait on this event loop, and
the tracker UDP socket (server/loop/tracker_udp.py), which the hub binds once and keeps.
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
    def __init__(self, config: LoopConfig, on_record: Callable[[list], None],
                 on_cue_channel: Callable[[socket.socket], None] | None = None):
        self.config = config
        self.on_record = on_record
        self.on_cue_channel = on_cue_channel
        self.tracker_sock: socket.socket | None = None  # the tracker UDP port, read by every loop process
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
        loop_ends = [theirs]
        feed_end = None
        if self.on_cue_channel is not None:
            feed_end, loop_cues = ipc.channel_pair()
            args += ["--cues-fd", str(loop_cues.fileno())]
            loop_ends.append(loop_cues)
        passed = [end.fileno() for end in loop_ends] + [self._doorbell.fd]
        if self.tracker_sock is not None:  # ours to keep: a restarted loop reads the same port
            args += ["--tracker-fd", str(self.tracker_sock.fileno())]
            passed.append(self.tracker_sock.fileno())
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "server.loop.process", *args, "--config", self.config.to_json()],
            pass_fds=tuple(passed), cwd=os.getcwd(),
            start_new_session=True)  # Ctrl-C in a terminal stops the hub, which stops the loop in order
        for end in loop_ends:  # the loop process holds them now
            end.close()
        self._sock = ours
        if feed_end is not None:
            self.on_cue_channel(feed_end)
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
