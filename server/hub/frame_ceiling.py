"""The ceiling on state frames a viewer is sent (docs/protocol.md "Frame rate ceiling"), I/O-free:
a token bucket on the injected clock that the hub's broadcaster spends one token of per frame.

The loop publishes a state record at `state_hz` and besides in every tick whose device cues
changed, so a tactile cue never waits for the cadence. A tracker jittering in contact changes the
cues almost every tick: up to 1000 records a second, and unpaced every viewer was sent 240-535
frames a second, more than any display shows, while the hub's CPU went to encoding and sending
them. The bucket lets `state_hz` + CUE_FRAMES_PER_S frames a second through, with a burst of
BURST: the cadence frames and a cue change right after one go at once; in a storm the latest
record goes when a token is back (latest-wins, its skipped frames' events in front of its own).
So in any one second a viewer gets at most `state_hz` + CUE_FRAMES_PER_S + BURST frames."""

from __future__ import annotations

import math

CUE_FRAMES_PER_S = 60.0  # cue changes beyond the cadence: a 120 Hz display's worth at the default 60 Hz
BURST = 2  # a cue frame right after a cadence frame is not held back


def frames_per_s(state_hz: float) -> float:
    """The steady ceiling for a loop publishing at `state_hz`."""
    return state_hz + CUE_FRAMES_PER_S


class FrameCeiling:
    def __init__(self, state_hz: float, now_ns: int, *, burst: int = BURST):
        self.rate_per_ns = frames_per_s(state_hz) / 1e9
        self.burst = float(burst)
        self._tokens = float(burst)
        self._tokens_ns = now_ns

    def _refill(self, now_ns: int) -> None:
        elapsed = max(0, now_ns - self._tokens_ns)  # a clock that steps back refills nothing
        self._tokens_ns = max(self._tokens_ns, now_ns)
        self._tokens = min(self.burst, self._tokens + elapsed * self.rate_per_ns)

    def wait_ns(self, now_ns: int) -> int:
        """Nanoseconds until a frame may go; 0: now."""
        self._refill(now_ns)
        if self._tokens >= 1.0 - 1e-9:  # float dust of the refill must not cost a frame a 1 ns wait
            return 0
        return max(1, math.ceil((1.0 - self._tokens) / self.rate_per_ns))

    def spend(self, now_ns: int) -> None:
        """A frame went (callers ask `wait_ns` first)."""
        self._refill(now_ns)
        self._tokens = max(0.0, self._tokens - 1.0)
