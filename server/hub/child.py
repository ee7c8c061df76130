"""A child process of the hub that talks over one SEQPACKET socket and is restarted if it dies.

Shared by the loop supervisor and the device host. Adapter only, on the asyncio loop: records
from the child are handed to `_on_record` (add_reader, no thread); records to it are sent
without blocking. A death is seen when the child's end of the socket closes (the kernel closes it
as the process exits, before it can be reaped), with a poll of the process as a backstop, and the
child is started again at once; only repeated crashes wait (RestartBackoff), so a crash cannot
take the server down silently and a crash loop cannot spin. Only the event loop's thread uses it
(server/hub/owner.py): a restart replaces the socket (and the loop's doorbell) under any caller.
`on_exit(what, returncode)` and `on_start(what)` tell the hub (its health) when a child goes
and comes.
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import socket
import subprocess
import time
from typing import Callable

from server import ipc
from server.hub.owner import Owner
from server.ipc.records import Channel, Malformed, Record

log = logging.getLogger("viestac.hub")

HEALTHY_S = 3.0       # up this long: the next death is a first death again (a crash loop dies in start-up, ~1 s)
BACKOFF_FIRST_S = 0.5  # the wait before restarting after a second death in a row, doubling
BACKOFF_MAX_S = 10.0
POLL_S = 0.2          # the backstop: a child whose socket somehow stays open is still seen dead
REAP_WAIT_S = 1.0     # its socket closed but the process lives on: killed after this


class RestartBackoff:
    """How long to wait before restarting a child that died (pure; the caller passes the time).

    The first death restarts at once; each further death within HEALTHY_S of the previous start
    waits BACKOFF_FIRST_S, doubling up to BACKOFF_MAX_S; a child that stayed up HEALTHY_S starts
    the count again."""

    def __init__(self, healthy_s: float = HEALTHY_S, first_s: float = BACKOFF_FIRST_S, max_s: float = BACKOFF_MAX_S):
        self.healthy_s, self.first_s, self.max_s = healthy_s, first_s, max_s
        self.crashes = 0  # deaths in a row, each within healthy_s of its start
        self._started_at: float | None = None

    def started(self, now_s: float) -> None:
        self._started_at = now_s

    def died(self, now_s: float) -> float:
        """The wait before the next start, in seconds."""
        if self._started_at is not None and now_s - self._started_at >= self.healthy_s:
            self.crashes = 0
        delay = 0.0 if self.crashes == 0 else min(self.first_s * 2 ** (self.crashes - 1), self.max_s)
        self.crashes += 1
        return delay


class ChildProcess:
    what = "child process"  # for the log
    channel: Channel  # the records the child sends (server/ipc/records.py)

    def __init__(self) -> None:
        self.proc: subprocess.Popen | None = None
        self.restarts = 0
        self.backoff = RestartBackoff()
        self.on_exit: Callable[[str, int | None], None] = lambda what, returncode: None
        self.on_start: Callable[[str], None] = lambda what: None
        self._sock: socket.socket | None = None
        self._watch: asyncio.Task | None = None
        self._restart: asyncio.Task | None = None
        self._closing = False
        self.owner = Owner(f"the {self.what}")  # bound by start() unless the app shares the hub's
        self._requests: dict[int, asyncio.Future] = {}  # asked of the child, waiting for its answer
        self._ids = itertools.count(1)

    # ---- what a kind of child says --------------------------------------------------------
    def _spawn(self, theirs: socket.socket) -> subprocess.Popen:
        """Start the process with `theirs` (the child's end of the socket) passed to it."""
        raise NotImplementedError

    def _on_record(self, record: Record) -> None:
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
        theirs.close()  # the child holds it now: when the child dies, our end reads EOF
        self._sock = ours
        self.backoff.started(time.monotonic())
        asyncio.get_running_loop().add_reader(ours.fileno(), self._readable)
        if self._watch is None:
            self._watch = asyncio.create_task(self._watchdog())
        self._notify(self.on_start, self.what)

    def _send(self, record: Record) -> bool:
        """One record without blocking; False if it could not go (full, or no child)."""
        self.owner.check()
        if self._sock is None:
            return False
        try:
            return ipc.send_record(self._sock, record)
        except OSError:  # the child is gone; it is being started again
            return False

    async def _ask(self, make: Callable[[int], Record], timeout_s: float, unavailable: type[Exception]) -> dict:
        """Send `make(request id)` and wait for the child's answer to that id (`_answered`);
        `unavailable` when it cannot go, times out or the child goes away (`_fail_requests`)."""
        request = next(self._ids)
        future = asyncio.get_running_loop().create_future()
        self._requests[request] = future
        if not self._send(make(request)):
            self._requests.pop(request, None)
            raise unavailable(f"the {self.what} is not running (restarting?)")
        try:
            return await asyncio.wait_for(future, timeout_s)
        except asyncio.TimeoutError:
            raise unavailable(f"the {self.what} did not answer within {timeout_s:g} s") from None
        finally:
            self._requests.pop(request, None)

    def _answered(self, request: int, result) -> None:
        """The child's answer to `_ask`'s request id (a late one, after a timeout, is dropped)."""
        future = self._requests.pop(request, None)
        if future is not None and not future.done():
            future.set_result(result)

    def _fail_requests(self, error: Exception) -> None:
        """The child is gone: what it was asked will never come; say so now, not at the timeout."""
        requests, self._requests = self._requests, {}
        for future in requests.values():
            if not future.done():
                future.set_exception(error)

    def _readable(self) -> None:
        try:
            records = ipc.drain(self._sock, self.channel)
        except ipc.PeerClosed:  # it is gone; drain handed over the records it sent last first
            asyncio.get_running_loop().remove_reader(self._sock.fileno())
            self._died()
            return
        for record in records:
            if isinstance(record, Malformed):
                log.error("a bad record from the %s: %s", self.what, record.error)
                continue
            try:
                self._on_record(record)
            except Exception:  # noqa: BLE001 - one bad record must not stop the reader
                log.exception("failed to handle a %s record from the %s", type(record).__name__, self.what)

    async def _watchdog(self) -> None:
        while not self._closing:
            await asyncio.sleep(POLL_S)
            if self.proc is not None and self.proc.poll() is not None:
                self._died()

    def _died(self) -> None:
        """The child is gone (its socket closed, or the poll saw it): restart it, once."""
        if self._closing or (self._restart is not None and not self._restart.done()):
            return
        self._restart = asyncio.get_running_loop().create_task(self._restart_child())

    async def _restart_child(self) -> None:
        proc = self.proc
        loop = asyncio.get_running_loop()
        give_up = loop.time() + REAP_WAIT_S
        while proc is not None and proc.poll() is None:  # closed as it exits: reaped within microseconds
            if loop.time() > give_up:
                log.error("%s closed its socket but did not exit; killing it", self.what)
                proc.kill()
                await asyncio.to_thread(proc.wait)
                break
            await asyncio.sleep(0.001)
        code = None if proc is None else proc.returncode
        self._close_socket()
        delay = self.backoff.died(time.monotonic())
        log.error("%s exited with code %s; restarting %s", self.what, code,
                  "now" if delay == 0 else f"in {delay:.1f} s ({self.backoff.crashes} crashes in a row)")
        self._notify(self.on_exit, self.what, code)
        if delay:
            await asyncio.sleep(delay)
        if self._closing:
            return
        self.restarts += 1
        self.start()

    def _notify(self, callback: Callable, *args) -> None:
        try:
            callback(*args)
        except Exception:  # noqa: BLE001 - a listener's bug must not stop restarts
            log.exception("the %s's lifecycle callback failed", self.what)

    def _close_socket(self) -> None:
        if self._sock is not None:
            try:
                asyncio.get_running_loop().remove_reader(self._sock.fileno())
            except (ValueError, RuntimeError):
                pass
            self._sock.close()
            self._sock = None
        self._closed()

    async def _stop(self, stop_record: Record, wait_s: float) -> None:
        """Ask the child to stop, wait up to `wait_s`, then kill it; no restart after this."""
        self._closing = True
        for task in (self._watch, self._restart):
            if task is not None:
                task.cancel()
        self._send(stop_record)
        if self.proc is not None:
            try:
                await asyncio.wait_for(asyncio.to_thread(self.proc.wait), wait_s)
            except asyncio.TimeoutError:
                self.proc.kill()
                await asyncio.to_thread(self.proc.wait)
        self._close_socket()
