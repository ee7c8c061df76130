"""One thread owns the hub: the event loop's (docs/architecture.md "The hub").

The hub, the loop supervisor and the device host are plain objects without locks; the mailbox
doorbell in particular is a read-modify-write of a shared counter (server/ipc/__init__.py), and a loop
restart replaces it. Everything that touches them runs on the thread of the event loop that
started them: WebSocket serving, the child processes' readers, and REST handlers (`async def`).
Code on another thread (the experiment engine, which REST runs on worker threads so SQLite never
blocks the event loop) reaches the hub through `Owner.call`.

`check()` is the cheap guard (one thread-id compare; skipped under `python -O`): a call from
another thread raises `WrongThread` instead of racing.
"""

from __future__ import annotations

import asyncio
import threading
from typing import Any, Callable

CALL_TIMEOUT_S = 10.0


class WrongThread(RuntimeError):
    """A hub object was used from a thread that does not own it."""


class Owner:
    def __init__(self, what: str = "the hub"):
        self.what = what
        self.thread: int | None = None  # None until bound: then anything goes (tests, start-up)
        self.loop: asyncio.AbstractEventLoop | None = None

    def bind(self) -> None:
        """The running event loop's thread owns from now on (called on that loop)."""
        self.loop = asyncio.get_running_loop()
        self.thread = threading.get_ident()

    @property
    def here(self) -> bool:
        return self.thread is None or threading.get_ident() == self.thread

    def check(self) -> None:
        if __debug__ and not self.here:
            raise WrongThread(f"{self.what} belongs to the event loop's thread; it was called from thread "
                              f"{threading.current_thread().name!r} (docs/architecture.md \"The hub\")")

    def call(self, fn: Callable[..., Any], *args, **kwargs) -> Any:
        """`fn(*args, **kwargs)` on the owner thread, from any thread; returns its result or raises
        its exception. On the owner thread itself (or before binding) it is a plain call."""
        if self.here:
            return fn(*args, **kwargs)

        async def run() -> Any:
            return fn(*args, **kwargs)

        done = asyncio.run_coroutine_threadsafe(run(), self.loop)
        try:
            return done.result(CALL_TIMEOUT_S)
        except TimeoutError:
            done.cancel()  # not run yet: it never will
            raise


class HubForWorkers:
    """The hub as the experiment engine (server/experiment/engine.py, HubPort) sees it from a
    worker thread: every call and read runs on the owner thread."""

    def __init__(self, hub, owner: Owner):
        self._hub = hub
        self._owner = owner

    @property
    def listeners(self) -> list:  # appended to once, when the engine is built (before serving)
        return self._hub.link.listeners

    @property
    def scenario_state(self) -> dict | None:
        return self._owner.call(getattr, self._hub.control, "state")

    @property
    def scenario_target(self) -> dict | None:
        return self._owner.call(self._hub.control.target)

    @property
    def last_state(self) -> dict | None:
        return self._owner.call(getattr, self._hub.link, "last_state")

    def switch_scenario(self, name: str, params: dict | None = None, seed: int = 0, force: bool = False) -> dict:
        return self._owner.call(self._hub.control.switch_scenario, name, params, seed, force)

    def set_trial(self, phase: str | None, params: dict | None = None, index: int = 0,
                  force: bool = False) -> dict | None:
        return self._owner.call(self._hub.control.set_trial, phase, params, index, force)

    def require_devices(self, scenario: str | None = None, force: bool = False) -> None:
        self._owner.call(self._hub.control.require_devices, scenario, force)

    def devices_needed(self, scenario: str | None = None) -> dict[str, tuple[str, ...]]:
        return self._owner.call(self._hub.control.devices_needed, scenario)

    def set_recording(self, every_n_ticks: int) -> None:
        self._owner.call(self._hub.link.set_recording, every_n_ticks)
