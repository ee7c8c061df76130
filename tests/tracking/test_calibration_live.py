"""The calibration routines through REST against a running server with a replay source."""

import json
import time
from pathlib import Path

import pytest

from tests.live_server import get_json, start_server, stop_server
from server.tracking import replay

pytestmark = pytest.mark.slow


def test_capture_then_calibrate_moves_the_tool_and_is_stored(tmp_path):
    rate = 120
    held = (0.3, -0.2, 1.4)  # a finger held still, in the source's frame
    csv = tmp_path / "held.csv"
    csv.write_text(replay.write_csv([i / rate for i in range(240)], [{"right.index.tip": held}] * 240))
    data = tmp_path / "data"
    proc, base = start_server("contact-angle", extra=["--tracker", f"replay:{csv}", "--data-dir", str(data)])
    try:
        deadline = time.monotonic() + 10
        while get_json(base + "/api/trackers?limit=1")["sources"][0]["status"] != "ok":
            assert time.monotonic() < deadline, "the replay source never became ok"
            time.sleep(0.05)
        captured = get_json(base + "/api/trackers/replay/capture", "POST", body={"seconds": 0.5})
        point = captured["points"]["right.index.tip"]
        assert point["mean"] == pytest.approx(list(held)) and point["spread"] < 1e-9 and point["samples"] > 30
        ref = [0.0, 0.1, 0.9]
        answer = get_json(base + "/api/trackers/replay/calibration", "PUT",
                          body={"method": "hold", "pairs": [{"source": point["mean"], "scene": ref}]})
        assert answer["calibration"]["offset"] == pytest.approx([-0.3, 0.3, -0.5])
        deadline = time.monotonic() + 5
        while (hip := get_json(base + "/api/state")["tools"][0]["hip"]) != pytest.approx(ref, abs=1e-6):
            assert time.monotonic() < deadline, f"the calibration was not applied: hip {hip}"
            time.sleep(0.05)
        stored = json.loads(Path(data, "trackers", "replay.calibration.json").read_text())
        assert stored["method"] == "hold" and stored["offset"] == pytest.approx([-0.3, 0.3, -0.5])
        bad = [{"source": [0, 0, 0], "scene": [0, 0, 0]}, {"source": [1, 0, 0], "scene": [1, 0, 0]},
               {"source": [2, 0, 0], "scene": [2, 0, 0]}]
        with pytest.raises(Exception) as refused:  # points on one line define no rotation
            get_json(base + "/api/trackers/replay/calibration", "PUT", body={"method": "points", "pairs": bad})
        assert refused.value.code == 422
        reset = get_json(base + "/api/trackers/replay/calibration", "DELETE")
        assert reset["calibration"]["method"] == "default"
        assert not Path(data, "trackers", "replay.calibration.json").exists()
        with pytest.raises(Exception) as unknown:
            get_json(base + "/api/trackers/nope/capture", "POST", body={"seconds": 0.5})
        assert unknown.value.code == 404
    finally:
        stop_server(proc)
