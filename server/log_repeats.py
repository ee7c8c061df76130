"""Repeated log lines, rate-limited with counts.

A line that keeps coming (a device's watchdog trip every half second on a loaded machine, a
reconnect loop) must not bury the rest of the log: a 33-minute run wrote 8,000 lines of "the
device's watchdog turned every actuator off (trip N)". Two lines are "the same" when they come
from the same logger at the same level and differ only in their numbers (`key`). The first one is
written at once; the ones that follow within `window_s` are counted, not written, and when the
window closes one summary line says how many there were: "<the latest of them> [repeated N times
in the last T s]". A window that closes with no repeat forgets the line, so its next occurrence is
written at once again.

`RepeatLimiter` is the sans-I/O rule (an injected clock, tested with made-up times);
`RepeatFilter` is the logging filter around it, installed on the root logger's handlers by
`limit_repeats()` where each process sets up its logging (server/cli.py, the device host, the
tracker host). A summary that is due is written with the next log line of any kind, and at exit.
"""

from __future__ import annotations

import atexit
import logging
import re
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass
from typing import Callable

WINDOW_S = 10.0  # at most one line per repeated message every 10 s
MAX_KEYS = 1000  # distinct messages tracked at once; the oldest is forgotten beyond that
_NUMBER = re.compile(r"\d+(?:\.\d+)?")


def key(logger: str, level: int, text: str) -> tuple[str, int, str]:
    """What makes two log lines repeats of each other: their logger, level and text without numbers."""
    return logger, level, _NUMBER.sub("#", text)


@dataclass
class _Window:
    start_s: float
    count: int = 0  # repeats held back in this window
    last: object = None  # the latest repeat held back (a LogRecord in the filter)


@dataclass(frozen=True)
class Summary:
    """The line that replaces `count` held-back repeats; `last` is the latest of them."""
    last: object
    count: int
    span_s: float

    def text(self, message: str) -> str:
        times = "once" if self.count == 1 else f"{self.count} times"
        return f"{message} [repeated {times} in the last {self.span_s:.0f} s]"


class RepeatLimiter:
    def __init__(self, window_s: float = WINDOW_S, max_keys: int = MAX_KEYS):
        if window_s <= 0:
            raise ValueError(f"window_s must be > 0, got {window_s}")
        self.window_s = window_s
        self.max_keys = max_keys
        self._windows: OrderedDict[object, _Window] = OrderedDict()

    def due(self, now_s: float) -> list[Summary]:
        """The summaries of the windows that closed by `now_s`. A window with repeats opens the
        next one (the line is still coming); one without is forgotten."""
        out = []
        for k, w in list(self._windows.items()):
            if now_s - w.start_s < self.window_s:
                continue
            if w.count:
                out.append(Summary(w.last, w.count, now_s - w.start_s))
                self._windows[k] = _Window(now_s)
            else:
                del self._windows[k]
        return out

    def offer(self, k: object, item: object, now_s: float) -> bool:
        """True: write `item` now (the first of its kind); False: it is a repeat, counted. Call
        `due(now_s)` first, so a closed window does not count this one."""
        w = self._windows.get(k)
        if w is None:
            self._windows[k] = _Window(now_s)
            while len(self._windows) > self.max_keys:
                self._windows.popitem(last=False)
            return True
        w.count += 1
        w.last = item
        return False

    def flush(self, now_s: float) -> list[Summary]:
        """Every pending summary, whether its window closed or not (at exit)."""
        out = [Summary(w.last, w.count, now_s - w.start_s) for w in self._windows.values() if w.count]
        self._windows.clear()
        return out


class RepeatFilter(logging.Filter):
    """A filter on a handler: holds back repeats and writes their summaries through that handler."""

    def __init__(self, handler: logging.Handler, window_s: float = WINDOW_S,
                 clock: Callable[[], float] = time.monotonic):
        super().__init__()
        self.handler = handler
        self.clock = clock
        self.limiter = RepeatLimiter(window_s)
        self._emitting = False
        self._lock = threading.RLock()  # the device host logs from several threads

    def filter(self, record: logging.LogRecord) -> bool:
        with self._lock:
            if self._emitting:  # a summary of ours on its way out (this thread, through the handler)
                return True
            now = self.clock()
            self._write(self.limiter.due(now))
            return self.limiter.offer(key(record.name, record.levelno, record.getMessage()), record, now)

    def flush(self) -> None:
        with self._lock:
            self._write(self.limiter.flush(self.clock()))

    def _write(self, summaries: list[Summary]) -> None:
        for s in summaries:
            last = s.last
            line = logging.makeLogRecord({**last.__dict__, "msg": s.text(last.getMessage()), "args": None,
                                          "exc_info": None, "exc_text": None})
            self._emitting = True
            try:
                self.handler.handle(line)
            finally:
                self._emitting = False


def limit_repeats(logger: logging.Logger | None = None, window_s: float = WINDOW_S) -> list[RepeatFilter]:
    """Install a RepeatFilter on every handler of `logger` (the root logger: call it right after
    logging.basicConfig); pending summaries are written at exit."""
    logger = logger or logging.getLogger()
    filters = []
    for handler in logger.handlers:
        if any(isinstance(f, RepeatFilter) for f in handler.filters):
            continue
        f = RepeatFilter(handler, window_s)
        handler.addFilter(f)
        atexit.register(f.flush)
        filters.append(f)
    return filters
