"""Audio underruns in health (server/hub/health.py): a note while they rise, never `degraded`."""

from server.hub.health import Health


def healthy(now_s: float) -> Health:
    h = Health()
    h.loop_started(0.0)
    h.device_host_started(0.0)
    h.state(now_s)
    return h


def test_rising_underruns_are_a_note_for_ten_seconds_and_no_reason():
    h = healthy(1.0)
    assert h.underruns({"coil": 0}, 1.0) is False
    assert h.underruns({"coil": 3}, 2.0) is True
    h.state(2.5)
    report = h.evaluate(2.5)
    assert report.status == "ok" and report.reasons == ()
    (note,) = [n for n in report.notes if n["code"] == "audio_underruns"]
    assert "'coil' has had 3 underruns" in note["message"] and note["since_s"] == 0.5
    assert h.underruns({"coil": 3}, 5.0) is False  # no new ones
    h.state(12.5)
    assert not [n for n in h.evaluate(12.5).notes if n["code"] == "audio_underruns"]
