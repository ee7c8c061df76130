"""Rate limits, pure (the caller passes the time): a token bucket, and a throttle of failed attempts."""

from __future__ import annotations


class TokenBucket:
    """`burst` tokens, refilled at `rate_per_s`; `take` spends one. A clock that steps back refills nothing."""

    def __init__(self, rate_per_s: float, burst: float, now_ns: int):
        if not rate_per_s > 0 or not burst >= 1:
            raise ValueError("a token bucket needs rate_per_s > 0 and burst >= 1")
        self.rate_per_s = float(rate_per_s)
        self.burst = float(burst)
        self.tokens = float(burst)
        self._at_ns = now_ns

    def _refill(self, now_ns: int) -> None:
        elapsed = max(0, now_ns - self._at_ns)
        self._at_ns = max(self._at_ns, now_ns)
        self.tokens = min(self.burst, self.tokens + elapsed * self.rate_per_s / 1e9)

    def take(self, now_ns: int) -> bool:
        self._refill(now_ns)
        if self.tokens >= 1.0:
            self.tokens -= 1.0
            return True
        return False

    def retry_after_s(self, now_ns: int) -> float:
        """Seconds until one token is there again (0 when one is there now)."""
        self._refill(now_ns)
        return max(0.0, (1.0 - self.tokens) / self.rate_per_s)


class FailureThrottle:
    """Failed attempts per key (a token's or a code's prefix hash, `guess_key`; never a peer
    address): `free` failures cost nothing, then each one blocks the key for base_s, 2·base_s,
    4·base_s ... up to max_s, and while it is blocked an attempt under that key is not checked at
    all. A success clears the key. At most `max_keys` keys are remembered; the oldest key that is
    not blocked goes first, so a flood of fresh guesses cannot push a blocked key out."""

    def __init__(self, free: int = 5, base_s: float = 1.0, max_s: float = 60.0, max_keys: int = 10_000):
        self.free = free
        self.base_s = base_s
        self.max_s = max_s
        self.max_keys = max_keys
        self._keys: dict[str, tuple[int, float]] = {}  # key -> (failures, blocked until), oldest first

    def blocked_for(self, key: str, now_s: float) -> float:
        """Seconds the key must still wait before it may try again (0: it may)."""
        entry = self._keys.get(key)
        return 0.0 if entry is None else max(0.0, entry[1] - now_s)

    def failed(self, key: str, now_s: float) -> None:
        failures, _ = self._keys.pop(key, (0, 0.0))
        failures += 1
        over = failures - self.free
        until = now_s + min(self.max_s, self.base_s * 2 ** (over - 1)) if over > 0 else 0.0
        self._keys[key] = (failures, until)
        while len(self._keys) > self.max_keys:
            idle = next((k for k, (_, blocked) in self._keys.items() if blocked <= now_s), None)
            del self._keys[idle if idle is not None else next(iter(self._keys))]

    def succeeded(self, key: str) -> None:
        self._keys.pop(key, None)
