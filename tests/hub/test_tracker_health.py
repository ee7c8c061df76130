"""Health says when tracking is lost (server/hub/tracker_health.py through server/hub/health.py and
the hub): a configured tracker source the tracker host reports lost, or a source the loop lists in
`tracking.lost` while a tool it drove is released, is `tracker_lost` (which source, since when, what
to check); `ok` again when it returns. Made-up times; the live test is tests/tracking/test_end_to_end.py."""

import asyncio

from server.hub.health import ALL_CODES, CODES
from server.hub.hub import Hub
from server.hub.tracker_health import TRACKER_CODES
from server.wire import codec
from tests.hub.test_health import ticking
from tests.hub.test_health_wiring import state_record
from tests.ipc import loop_state

LEAP_ID = "udp:127.0.0.1:40001"


def leap(status: str, **kw) -> dict:
    entry = {"name": "leap", "kind": "leap", "target": "ws://127.0.0.1:6437/v6.json", "status": status,
             "reasons": [] if status != "lost" else ["no sample for 420 ms"], "note": "connected",
             "client_id": LEAP_ID}
    entry.update(kw)
    return entry


def test_a_configured_source_the_tracker_host_reports_lost_is_tracker_lost_until_it_returns():
    health = ticking()
    health.trackers([leap("ok")], 0.0)
    assert health.evaluate(0.01).status == "ok"
    assert health.trackers([leap("lost", note="no Leap service at ws://127.0.0.1:6437/v6.json; retrying")], 0.1)
    health.state(0.3)
    report = health.evaluate(0.3)
    assert report.status == "degraded" and report.codes == {"tracker_lost"}
    reason = report.reasons[0]
    assert "tracker source 'leap'" in reason["message"] and "no sample for 420 ms" in reason["message"]
    assert "retrying" in reason["message"] and "Leap Motion service" in reason["message"]
    assert reason["since_s"] == 0.2
    health.trackers([leap("degraded", reasons=["a gap in the last 2 s"])], 0.4)
    health.state(0.4)
    assert health.evaluate(0.4).status == "ok", "back (a recent gap is not a loss)"


def test_the_loops_lost_source_names_its_released_fingers_under_the_configured_sources_name():
    health = ticking()
    health.trackers([leap("lost")], 0.1)
    assert health.tracking([LEAP_ID], ["right.index.tip"], 0.05)
    health.state(0.2)
    report = health.evaluate(0.2)
    assert [r["code"] for r in report.reasons] == ["tracker_lost"], "one source, one reason"
    assert "finger right.index.tip released" in report.reasons[0]["message"]
    assert report.reasons[0]["since_s"] == 0.15, "since the loop first listed it"
    assert not health.tracking([LEAP_ID], ["right.index.tip"], 0.3), "unchanged"


def test_a_bridge_or_client_the_loop_lists_lost_is_a_reason_only_while_a_tool_it_drove_is_released():
    health = ticking()
    health.tracking(["udp:127.0.0.1:5555"], [], 0.1)
    health.state(0.2)
    assert health.evaluate(0.2).status == "ok", "a lost source that drove no tool (drawn points only)"
    health.tracking(["udp:127.0.0.1:5555", 7], ["right.index.tip", "right.thumb.tip"], 0.3)
    health.state(0.4)
    report = health.evaluate(0.4)
    messages = [r["message"] for r in report.reasons]
    assert report.codes == {"tracker_lost"} and len(messages) == 2
    assert "'udp:127.0.0.1:5555' stopped sending" in messages[0] and "client 7" in messages[1]
    assert "fingers right.index.tip, right.thumb.tip released" in messages[0]
    health.tracking([], [], 0.5)
    health.state(0.5)
    assert health.evaluate(0.5).status == "ok"


def test_a_replay_that_ran_once_and_finished_is_a_note_not_a_fault():
    health = ticking()
    health.trackers([leap("lost", name="replay", kind="replay", target="walk.csv", note="replay finished")], 0.1)
    health.tracking([LEAP_ID], ["right.index.tip"], 0.1)
    health.state(0.2)
    report = health.evaluate(0.2)
    assert report.status == "ok" and [n["code"] for n in report.notes] == ["tracker_finished"]


def test_every_tracking_code_is_declared_beside_the_others():
    assert set(ALL_CODES) == set(CODES) | set(TRACKER_CODES) and "tracker_lost" in ALL_CODES
    health = ticking()
    health.trackers([leap("lost")], 0.0)
    assert health.evaluate(0.01).codes <= set(ALL_CODES)


def test_the_hub_turns_the_tracker_hosts_reports_and_the_loops_tracking_into_health():
    async def go():
        hub = Hub(server_name="test", tick_hz=1000, state_hz=60, send_to_loop=lambda record: True)
        hub.health_feed.on_child_start("loop")
        hub.health_feed.on_child_start("device_host")
        hub.link.on_loop_record(loop_state(state_record()))
        assert hub.health_feed.check_health().status == "ok"
        hub.health_feed.on_tracker_sources([leap("ok")])
        assert hub.health_feed.check_health().status == "ok"
        lost = dict(state_record(), tracking={"lost": [LEAP_ID]},
                    tools=[{"name": "right.index.tip", "hip": [0, 0, 0], "proxy": [0, 0, 0], "contact": False,
                            "lost": True}])
        hub.link.on_loop_record(loop_state(lost))
        report = hub.health_feed.check_health()
        assert report.codes == {"tracker_lost"} and "right.index.tip" in report.reasons[0]["message"]
        assert codec.decode(hub.fanout.health_frames["json"], "json")["reasons"][0]["code"] == "tracker_lost"
        hub.health_feed.on_tracker_sources([leap("lost")])
        assert [r["code"] for r in hub.health_feed.check_health().reasons] == ["tracker_lost"]
        back = dict(state_record(), tracking={"lost": []}, tools=[])
        hub.link.on_loop_record(loop_state(back))
        hub.health_feed.on_tracker_sources([leap("ok")])
        assert hub.health_feed.check_health().status == "ok"

    asyncio.run(go())
