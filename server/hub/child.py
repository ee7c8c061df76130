"""A child process of the hub that talks over one SEQPACKET socket and is restarted if it dies.

Shared by the loop supervisor and the device host. Adapter only, on the asyncio loop: records
from the child are handed to `_on_record` (add_reader, no thread); records to it are sent
without blocking. A dead child is logged and started again with backoff (0.5 s, doubling up to
10 s), so a crash cannot take the server down silently. Only the event loop's thread uses it
(server/hub/owner.py): a restart replaces the socket (and the loop's doorbell) under any caller.
"""

from __future__ import annotations

import asyncio
import logging
import socket
import subprocess

from server import ipc
from server.hub.owner import Owner

log = logging.getLogger("viestac.hub")


class ChildProcess:
    what = "child process"  # for the log

    def __init__(self) -> None:
        self.proc: subprocess.Popen | None = None
        self.restarts = 0
        self._sock: socket.socket | None = None
        self._watch: asyncio.Task | None = None
        self._closing = False
        self.owner = Owner(f"the {self.what}")  # bound by start() unless the app shares the hub's

    # ---- what a kind of child says --------------------------------------------------------
    def _spawn(self, theirs: socket.socket) -> subprocess.Popen:
        """Start the process with `theirs` (the child's end of the socket) passed to it."""
        raise NotImplementedError

    def _on_record(self, record: list) -> None:
        raise NotImplementedError

    def _closed(self) -> None:
        """The socket to a (dead or stopped) child was closed: drop what belonged to it."""

    # ---- shared ---------------------------------------------------------------------------
    @property
    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def start(self) -> None:
        if self.owner.thread is None:
            self.owner.bind()
        ours, theirs = ipc.channel_pair()
        self.proc = self._spawn(theirs)
        theirs.close()  # the child holds it now
        self._sock = ours
        asyncio.get_running_loop().add_reader(ours.fileno(), self._readable)
        if self._watch is None:
            self._watch = asyncio.create_task(self._watchdog())

    def _send(self, record: list) -> bool:
        """One record without blocking; False if it could not go (full, or no child)."""
        self.owner.check()
        if self._sock is None:
            return False
        try:
            return ipc.send_record(self._sock, record)
        except OSError:  # the child is gone; the watchdog starts it again
            return False

    def _readable(self) -> None:
        try:
            records = ipc.drain(self._sock)
        except ipc.PeerClosed:
            asyncio.get_running_loop().remove_reader(self._sock.fileno())
            return
        for record in records:
            try:
                self._on_record(record)
            except Exception:  # noqa: BLE001 - one bad record must not stop the reader
                log.exception("failed to handle a record of kind %r from the %s",
                              record[0] if record else None, self.what)

    async def _watchdog(self) -> None:
        backoff = 0.5
        while not self._closing:
            await asyncio.sleep(0.2)
            if self.proc is not None and self.proc.poll() is not None and not self._closing:
                log.error("%s exited with code %s; restarting in %.1f s", self.what, self.proc.returncode, backoff)
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
        self._closed()

    async def _stop(self, stop_record: list, wait_s: float) -> None:
        """Ask the child to stop, wait up to `wait_s`, then kill it; no restart after this."""
        self._closing = True
        if self._watch:
            self._watch.cancel()
        self._send(stop_record)
        if self.proc is not None:
            try:
                await asyncio.wait_for(asyncio.to_thread(self.proc.wait), wait_s)
            except asyncio.TimeoutError:
                self.proc.kill()
        self._close_socket()
