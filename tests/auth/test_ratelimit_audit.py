"""Token bucket, failure throttle, audit rows."""

from __future__ import annotations

import pytest

from server.auth import open_book
from server.auth.audit import Audit
from server.auth.identity import Identity
from server.auth.ratelimit import FailureThrottle, TokenBucket


def test_bucket_burst_then_rate():
    bucket = TokenBucket(100.0, 4, now_ns=0)
    assert [bucket.take(0) for _ in range(5)] == [True] * 4 + [False]
    assert bucket.retry_after_s(0) == pytest.approx(0.01)
    assert not bucket.take(9_000_000)  # 9 ms: 0.9 of a token
    assert bucket.take(10_000_000)
    assert bucket.take(10_000_000_000) and bucket.tokens == pytest.approx(3.0)  # capped at the burst
    assert TokenBucket(1.0, 1, now_ns=100).take(100)  # a full bucket at once


def test_bucket_ignores_a_clock_stepping_back():
    bucket = TokenBucket(1000.0, 1, now_ns=1_000_000_000)
    assert bucket.take(1_000_000_000)
    assert not bucket.take(0)
    assert not bucket.take(1_000_000_000)
    assert bucket.take(1_001_000_000)


def test_throttle_doubles_up_to_the_cap_and_clears_on_success():
    t = FailureThrottle(free=2, base_s=1.0, max_s=5.0)
    t.failed("p", 0.0), t.failed("p", 0.0)
    assert t.blocked_for("p", 0.0) == 0.0
    waits = []
    for _ in range(5):
        t.failed("p", 100.0)
        waits.append(t.blocked_for("p", 100.0))
    assert waits == [1.0, 2.0, 4.0, 5.0, 5.0]
    assert t.blocked_for("p", 104.0) == pytest.approx(1.0) and t.blocked_for("other", 100.0) == 0.0
    t.succeeded("p")
    assert t.blocked_for("p", 100.0) == 0.0


def test_throttle_memory_is_bounded():
    t = FailureThrottle(free=0, max_keys=3)
    for i in range(10):
        t.failed(f"10.0.0.{i}", 0.0)
    assert t.blocked_for("10.0.0.0", 0.0) == 0.0 and t.blocked_for("10.0.0.9", 0.0) == 1.0
    assert len(t._keys) == 3


def test_audit_rows_by_site_and_session(tmp_path, clock):
    store, _ = open_book(tmp_path, clock)
    audit = Audit(store, clock)
    a = Identity("aaaa0001", "experimenter", "lab-a")
    admin = Identity("adad0001", "admin")
    audit.record(a, "trial.start", "session s1 trial 1", "ok", session_id="s1")
    clock.advance(1)
    audit.record(admin, "lease.force_release", "lease", "ok", detail={"from": "aaaa0001"})
    audit.record(admin, "trial.exclude", "session s1 trial 1", "ok", session_id="s1", site="lab-a")
    audit.record(None, "scenario.switch", "ball", "401")
    rows = audit.rows()
    assert [r["action"] for r in rows] == ["trial.start", "lease.force_release", "trial.exclude", "scenario.switch"]
    assert rows[0] | {"id": 0} == {"id": 0, "utc": clock.now - 1, "token_id": "aaaa0001", "role": "experimenter",
                                  "site": "lab-a", "action": "trial.start", "target": "session s1 trial 1",
                                  "result": "ok", "session_id": "s1", "detail": None}
    assert rows[1]["detail"] == {"from": "aaaa0001"}
    assert [r["action"] for r in audit.rows(site="lab-a")] == ["trial.start", "trial.exclude"]
    assert [r["action"] for r in audit.rows(session_id="s1", limit=1)] == ["trial.exclude"]
    assert audit.rows(site="lab-b") == []
    store.close()
