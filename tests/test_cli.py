"""`viestac serve` refuses bad settings up front with a clear message (no half-started server)."""

import json
import subprocess
import sys

import pytest

from server.config import Settings


def _serve(*args):
    return subprocess.run([sys.executable, "-m", "server.cli", "serve", "--port", "0", *args],
                          capture_output=True, text=True, timeout=60)


def test_unknown_scenario_gets_a_hint():
    result = _serve("--scenario", "contact-angel")
    assert result.returncode == 2 and "did you mean" in result.stderr


def test_bad_scene_file_names_the_field(tmp_path):
    bad = tmp_path / "scene.json"
    bad.write_text(json.dumps({"name": "x", "objects": [{"id": "a", "shape": {"type": "box", "size": [1, 1]}}]}))
    result = _serve("--scene", str(bad))
    assert result.returncode == 2 and "objects[0]" in result.stderr


@pytest.mark.parametrize("kwargs", [{"port": 70000}, {"state_hz": 0}, {"tick_hz": 50}, {"gate_band": -0.1},
                                    {"gate_dwell_s": 5}])
def test_settings_validation(kwargs):
    with pytest.raises(ValueError):
        Settings(**kwargs)


def test_settings_reach_the_loop():
    config = Settings(gate_band=0.001, gate_dwell_s=0.05, state_hz=90).loop_config()
    assert (config.gate_band, config.gate_min_on_s, config.gate_min_off_s, config.state_hz) == (0.001, 0.05, 0.05, 90)
    assert config.scenario == "contact-angle-v1"
