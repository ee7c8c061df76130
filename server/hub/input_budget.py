"""One /ws client's input budget (docs/protocol.md "Input budget"), I/O-free: `input` and
`answer` messages spend tokens of a bucket refilled on the injected clock, and the replies to
what the client is refused are paced, so one client's key flood can neither flood the loop's
events nor every viewer's state frames, nor its own socket with errors.

A person types at most ~10-15 keys/s and a held key repeats at ~30/s (each repeat a `down`), so
50/s never limits a person; a burst of 20 covers chords and a quick series of presses. A client
over it loses inputs, never its connection."""

from __future__ import annotations

INPUT_BURST = 20
INPUT_RATE_PER_S = 50.0
RATE_LIMITED_ERROR_EVERY_NS = 1_000_000_000  # at most one `rate_limited` error a second per client
FORBIDDEN_TRACKER_ERROR_EVERY_NS = 1_000_000_000  # a refused tracker stream: one `forbidden` a second


class InputBudget:
    def __init__(self, opened_ns: int):
        self._tokens = float(INPUT_BURST)
        self._tokens_ns = opened_ns
        self._replied_ns: dict[str, int] = {}  # what was refused → when its last error was queued

    def spend(self, now_ns: int) -> bool:
        """One token for an input or an answer; False when the budget is spent."""
        elapsed = max(0, now_ns - self._tokens_ns)  # a clock that steps back refills nothing
        self._tokens_ns = max(self._tokens_ns, now_ns)
        self._tokens = min(float(INPUT_BURST), self._tokens + elapsed * (INPUT_RATE_PER_S / 1e9))
        if self._tokens >= 1.0:
            self._tokens -= 1.0
            return True
        return False

    def reply_due(self, refused: str, every_ns: int, now_ns: int) -> bool:
        """An error may be sent for this refusal now (at most one per `every_ns` per kind); the
        rest are counted without a reply."""
        last = self._replied_ns.get(refused)
        if last is not None and now_ns - last < every_ns:
            return False
        self._replied_ns[refused] = now_ns
        return True
