"""Health of one tracker source (rate, gaps, age of the latest sample, confidence, status).

Status: `lost` when no sample arrived for longer than the source's ttl (the loop has released
its tools by then) or none ever came; `degraded` when the rate over the last second is below
half the nominal rate, the mean confidence is below MIN_CONFIDENCE, or a gap (an interval over
GAP_PERIODS nominal periods, at least GAP_MIN_S) ended within the last RECENT_S; `ok` otherwise.

Pure: the caller passes monotonic times in seconds.
"""

from __future__ import annotations

from collections import deque

GAP_PERIODS = 4.0
GAP_MIN_S = 0.040
RECENT_S = 2.0
RATE_WINDOW_S = 1.0
MIN_CONFIDENCE = 0.3


class SourceHealth:
    def __init__(self, name: str, kind: str, nominal_hz: float, ttl_s: float):
        self.name, self.kind, self.nominal_hz, self.ttl_s = name, kind, float(nominal_hz), float(ttl_s)
        self.gap_s = max(GAP_PERIODS / self.nominal_hz, GAP_MIN_S)
        self.samples = 0
        self.gaps = 0
        self.longest_gap_s = 0.0
        self.connected = False
        self.note = ""  # what the shell last said (connecting, focus lost, file ended)
        self._times: deque[float] = deque()
        self._conf: deque[float] = deque()
        self._last: float | None = None
        self._last_gap_end: float | None = None

    def sample(self, now_s: float, confidence: float = 1.0) -> None:
        if self._last is not None:
            interval = now_s - self._last
            if interval > self.gap_s:
                self.gaps += 1
                self.longest_gap_s = max(self.longest_gap_s, interval)
                self._last_gap_end = now_s
        self._last = now_s
        self.samples += 1
        self._times.append(now_s)
        self._conf.append(float(confidence))
        self._trim(now_s)

    def _trim(self, now_s: float) -> None:
        while self._times and self._times[0] < now_s - RATE_WINDOW_S:
            self._times.popleft()
            self._conf.popleft()

    def snapshot(self, now_s: float) -> dict:
        self._trim(now_s)
        rate = len(self._times) / RATE_WINDOW_S
        confidence = sum(self._conf) / len(self._conf) if self._conf else None
        age_s = None if self._last is None else now_s - self._last
        reasons = []
        if age_s is None or age_s > self.ttl_s:
            status = "lost"
            reasons.append("no samples" if age_s is None else f"no sample for {age_s * 1000:.0f} ms")
        else:
            if rate < 0.5 * self.nominal_hz:
                reasons.append(f"rate {rate:.0f}/s below half of {self.nominal_hz:.0f}/s")
            if confidence is not None and confidence < MIN_CONFIDENCE:
                reasons.append(f"confidence {confidence:.2f}")
            if self._last_gap_end is not None and now_s - self._last_gap_end < RECENT_S:
                reasons.append("a gap in the last 2 s")
            status = "degraded" if reasons else "ok"
        return {"name": self.name, "kind": self.kind, "status": status, "reasons": reasons,
                "connected": self.connected, "note": self.note,
                "rate_hz": round(rate, 1), "nominal_hz": self.nominal_hz, "samples": self.samples,
                "gaps": self.gaps, "longest_gap_ms": round(self.longest_gap_s * 1000, 1),
                "age_ms": None if age_s is None else round(age_s * 1000, 1),
                "confidence": None if confidence is None else round(confidence, 3),
                "ttl_ms": round(self.ttl_s * 1000, 1)}
