"""The hub's numbered events: ranges by number, and a bounded memory (the newest are kept)."""

from server.hub.event_log import EventLog


def test_events_are_numbered_in_order_and_a_range_gives_them_back():
    log = EventLog()
    assert log.add([]) == 0 and log.between(0, 0) == []
    assert log.add([{"n": 1}, {"n": 2}]) == 2 and log.add([{"n": 3}]) == 3
    assert log.between(0, 3) == [{"n": 1}, {"n": 2}, {"n": 3}]
    assert log.between(1, 2) == [{"n": 2}] and log.between(3, 3) == [] and log.between(3, 1) == []


def test_only_the_newest_events_are_kept():
    log = EventLog(kept=3)
    log.add([{"n": k} for k in range(1, 6)])
    assert log.last == 5 and log.between(0, 5) == [{"n": 3}, {"n": 4}, {"n": 5}]
