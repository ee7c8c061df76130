from server.tracking.health import SourceHealth


def feed(h, start, end, hz, conf=1.0):
    t = start
    while t < end:
        h.sample(t, conf)
        t += 1 / hz
    return t


def test_ok_at_nominal_rate():
    h = SourceHealth("leap", "leap", 110, 0.04)
    t = feed(h, 0.0, 3.0, 110)
    snap = h.snapshot(t)
    assert snap["status"] == "ok", snap
    assert 105 <= snap["rate_hz"] <= 112
    assert snap["gaps"] == 0 and snap["age_ms"] < 10


def test_lost_after_ttl_then_degraded_by_the_gap_then_ok():
    h = SourceHealth("leap", "leap", 110, 0.04)
    t = feed(h, 0.0, 2.0, 110)
    assert h.snapshot(t + 0.03)["status"] == "ok"
    assert h.snapshot(t + 0.05)["status"] == "lost"
    t2 = feed(h, t + 0.5, t + 1.7, 110)
    snap = h.snapshot(t2)
    assert snap["status"] == "degraded" and snap["gaps"] == 1 and snap["longest_gap_ms"] >= 500
    t3 = feed(h, t2, t2 + 1.5, 110)
    assert h.snapshot(t3)["status"] == "ok"


def test_low_confidence_and_low_rate_degrade():
    h = SourceHealth("leap", "leap", 110, 0.06)
    t = feed(h, 0.0, 3.0, 110, conf=0.1)
    assert h.snapshot(t)["status"] == "degraded"
    h2 = SourceHealth("leap", "leap", 110, 0.06)
    t = feed(h2, 0.0, 3.0, 30)
    assert h2.snapshot(t)["status"] == "degraded"


def test_never_sampled_is_lost():
    assert SourceHealth("x", "replay", 120, 0.04).snapshot(5.0)["status"] == "lost"
