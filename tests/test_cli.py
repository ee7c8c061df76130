"""`viestac serve` refuses bad settings up front with a clear message (no half-started server)."""

import json
import os
import subprocess
import sys

import pytest

from tests.live_server import admin_token
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


def test_bad_device_option_is_refused_before_anything_starts(tmp_path):
    result = _serve("--device", "ferovibe@/dev/ttyUSB0")
    assert result.returncode == 2 and "built-in: fingertac, ferrovibe" in result.stderr
    bad = tmp_path / "rig.toml"
    bad.write_text("[[device]]\nprofile = 'ferrovibe'\nport = '/dev/ttyUSB0'\nspeed = 9600\n")
    result = _serve("--devices", str(bad))
    assert result.returncode == 2 and "speed" in result.stderr and str(bad) in result.stderr


def test_viestac_devices_lists_ports_configured_devices_and_a_running_servers_status(live_server, tmp_path):
    config = tmp_path / "rig.toml"
    config.write_text(f"[[device]]\nname = 'tac'\nprofile = 'fingertac'\nport = '{tmp_path / 'absent'}'\n")
    result = subprocess.run([sys.executable, "-m", "server.cli", "devices", "--devices", str(config),
                             "--server", live_server.http_url], capture_output=True, text=True, timeout=60,
                            env={**os.environ, "VIESTAC_TOKEN": admin_token(live_server.http_url)})
    assert result.returncode == 0, result.stderr
    assert "Serial ports" in result.stdout
    assert f"Configured tac (fingertac) on {tmp_path / 'absent'}: not present" in result.stdout
    # the live server runs the simulated rig: both emulated devices are connected, with firmware and RTT
    for model in ("fingertac", "ferrovibe"):
        line = next(row for row in result.stdout.splitlines() if row.strip().startswith(model))
        assert "connected" in line and "firmware 1.0.0" in line and "rtt" in line
    as_json = subprocess.run([sys.executable, "-m", "server.cli", "devices", "--json", "--server", "http://127.0.0.1:9"],
                             capture_output=True, text=True, timeout=60)
    report = json.loads(as_json.stdout)
    assert report["server"] is None and "no server at http://127.0.0.1:9" in report["server_error"]


def test_viestac_emulate_prints_its_port_and_records_the_timeline(tmp_path):
    import csv
    import time

    from server.core.cues import PulseTrain
    from devices.manager import DeviceConfig, DeviceManager

    link, timeline = tmp_path / "ft", tmp_path / "ft.csv"
    proc = subprocess.Popen([sys.executable, "-m", "server.cli", "emulate", "fingertac", "--link", str(link),
                             "--timeline", str(timeline)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        first = proc.stdout.readline()
        assert first.startswith("fingertac emulator on /dev/pts/") and str(link) in first
        assert proc.stdout.readline().strip() == str(link)
        manager = DeviceManager([DeviceConfig.parse(f"fingertac@{link}")], reopen_interval_s=0.1)
        manager.start()
        deadline = time.monotonic() + 3
        while manager.status()["fingertac"] != "connected":
            assert time.monotonic() < deadline
            time.sleep(0.01)
        manager.submit((PulseTrain(20, 30),))
        time.sleep(0.3)
        manager.stop()
    finally:
        proc.terminate()
        _, err = proc.communicate(timeout=5)
    assert proc.returncode == 0 and "fingertac emulator stopped" in err
    with timeline.open() as f:
        rows = list(csv.DictReader(f))
    pulses = [r for r in rows if r["mode"] == "pulse" and r["gate"] == "1" and r["cause"] == "schedule"]
    assert len(pulses) >= 8 and {r["channel"] for r in pulses} == {"0", "1"} and pulses[0]["carrier_hz"] == "235"


def test_a_scenario_no_device_of_the_rig_can_show_is_refused_at_start():
    result = _serve("--scenario", "friction-temperature")
    assert result.returncode == 2
    assert "needs a device that shows friction or temperature" in result.stderr and "--force" in result.stderr
    assert "ferrovibe (ferrovibe) cannot show the temperature cue" in result.stderr


@pytest.mark.parametrize("args, message", [
    (["--scenario", "texture", "--param", "period_us=3500"], "texture-v1.period_us must be one of"),
    (["--scenario", "texture", "--param", "speed=1"], "unknown parameter(s) speed"),
    (["--scenario", "texture", "--param", "period_us"], "expected KEY=VALUE"),
    (["--rig", "fingertac,thermotac"], "no built-in profile 'thermotac'"),
])
def test_bad_scenario_parameters_and_rig_models_are_named(args, message):
    result = _serve(*args)
    assert result.returncode == 2 and message in result.stderr, result.stderr


def test_scenario_parameters_reach_the_loop():
    config = Settings(scenario="texture", scenario_params={"period_us": 3000, "velocity": -0.2}).loop_config()
    assert config.scenario_params["period_us"] == 3000.0 and config.scenario_params["velocity"] == -0.2
    assert config.scenario_params["skin"] == "", "defaults are filled in"


class _Served(Exception):
    """Raised in place of the app: the settings `viestac serve` built, before anything listens."""


def _served_settings(monkeypatch, *args) -> Settings:
    import server.app
    from server import cli

    def capture(settings, **_):
        raise _Served(settings)

    monkeypatch.setattr(server.app, "create_app", capture)
    with pytest.raises(_Served) as served:
        cli.main(["serve", "--port", "0", "--tracker-udp", "off", "--no-rig", *args])
    return served.value.args[0]


def test_serve_with_a_scene_file_runs_free_v1_on_it_and_a_named_scenario_over_it(monkeypatch, tmp_path):
    from server.core.scene import Scene
    from server.loop.process import build_core

    path = tmp_path / "scene.json"
    path.write_text(json.dumps({"name": "ball", "objects": [{"id": "ball", "shape": {"type": "sphere", "radius": 0.3}}]}))
    core = build_core(_served_settings(monkeypatch, "--scene", str(path)).loop_config())
    assert (core.sim.scenario.id, core.sim.scene) == ("free-v1", Scene.load(path))
    core = build_core(_served_settings(monkeypatch, "--scenario", "stiffness", "--scene", str(path)).loop_config())
    assert (core.sim.scenario.id, core.sim.scene) == ("stiffness-v1", Scene.load(path))
    assert _served_settings(monkeypatch).scenario == "contact-angle-v1"


@pytest.mark.parametrize("flag", ["--help", "-h"])
def test_viestac_emulate_help_prints_the_usage_and_exits_0(flag):
    result = subprocess.run([sys.executable, "-m", "server.cli", "emulate", flag], capture_output=True, text=True,
                            timeout=60)
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("usage: viestac emulate {fingertac,ferrovibe,devkit,leap}")
    assert "viestac emulate KIND --help" in result.stdout


def test_other_commands_still_refuse_unknown_options():
    result = subprocess.run([sys.executable, "-m", "server.cli", "devices", "--no-such-option"], capture_output=True,
                            text=True, timeout=60)
    assert result.returncode == 2 and "unrecognized arguments: --no-such-option" in result.stderr
