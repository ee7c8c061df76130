"""The devkit model: temperature and friction from a cue to the emulated actuator timeline.

Cue → CueEncoder → DeviceSession → pyserial → pty → emulator (the C firmware core) → timeline,
with nothing mocked, next to a FingerTac that must refuse the same cues."""

from __future__ import annotations

import csv
import struct
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from server.core.cues import Friction, Temperature, Texture
from devices.emulator import TIMELINE_COLUMNS, Emulator, edge_row
from devices.encoder import NEUTRAL_SKIN_C, CueEncoder
from devices.firmware_binding import MODELS, Firmware, encode_frame
from devices.manager import DeviceConfig, DeviceManager
from devices.messages import ALL_CHANNELS, SetFriction, SetTemperature, cap_names
from devices.ports import PortSpec
from devices.profiles import DEVKIT, PROFILES, profile_by_model
from devices.rig import SimulatedRig
from tests.devices.test_serial_path import wait_for


def read_timeline(path) -> list[dict[str, str]]:
    """The rows flushed so far (an emulator flushes its CSV every 0.2 s)."""
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        if reader.fieldnames is None:
            return []
        assert tuple(reader.fieldnames) == TIMELINE_COLUMNS
        return list(reader)


@pytest.fixture
def devkit_and_fingertac(tmp_path):
    """Both emulators on ptys behind one DeviceManager; everything stopped afterwards."""
    errors = []
    old_hook = threading.excepthook
    threading.excepthook = lambda args: errors.append(args)  # no exception may escape a device thread
    emulators = {model: Emulator(model, link=tmp_path / model, timeline=tmp_path / f"{model}.csv")
                 for model in ("devkit", "fingertac")}
    for emulator in emulators.values():
        emulator.start()
    manager = DeviceManager([DeviceConfig(model, profile_by_model(model), PortSpec.parse(str(tmp_path / model)))
                             for model in emulators], reopen_interval_s=0.1)
    manager.start()
    try:
        wait_for(lambda: set(manager.status().values()) == {"connected"}, 3.0, "the devices never all connected")
        yield emulators, manager
    finally:
        manager.stop()
        for emulator in emulators.values():
            emulator.stop()
        threading.excepthook = old_hook
    assert not errors, f"exceptions escaped device threads: {[str(e.exc_value) for e in errors]}"


def test_profile_matches_the_firmware_model():
    assert profile_by_model("devkit") is DEVKIT and set(MODELS) == set(PROFILES)
    for model, profile in PROFILES.items():
        core = Firmware(model)
        assert cap_names(core.caps) == profile.caps, model
        assert (core.channels, core.carrier_hz) == (len(profile.channels), profile.carrier_hz), model
        assert ".".join(map(str, core.firmware)) == profile.firmware, model
    assert DEVKIT.table_row() == {"stiffness": "(!)", "macro_roughness": "-", "fine_roughness": "!",
                                  "temperature": "!", "friction": "!"}


def test_encoder_accepts_on_devkit_and_refuses_on_fingertac():
    cues = (Temperature(celsius=40), Friction(coefficient=0.8))
    devkit = CueEncoder(DEVKIT).encode(cues)
    assert devkit.refusals == ()
    assert devkit.commands["temperature"] == SetTemperature(ALL_CHANNELS, 4000)
    assert devkit.commands["friction"] == SetFriction(ALL_CHANNELS, 800)
    fingertac = CueEncoder(profile_by_model("fingertac")).encode(cues)
    assert [(r.cue, r.code) for r in fingertac.refusals] == [("temperature", "not_displayed"),
                                                             ("friction", "not_displayed")]
    assert "temperature" not in fingertac.commands and "friction" not in fingertac.commands


def test_timeline_row_leaves_layers_that_are_off_empty():
    core = Firmware("devkit")
    core.receive(encode_frame(0x12, 1, struct.pack("<Bh", 0, 4_000)), 10)   # SET_TEMPERATURE 40 °C
    core.receive(encode_frame(0x1F, 2, b"\x00"), 20)                        # STOP
    rows = [dict(zip(TIMELINE_COLUMNS, edge_row(e))) for e in core.advance(20)]
    assert [(r["t_us"], r["temperature_c"], r["friction"], r["cause"]) for r in rows] == [
        (10, 40.0, "", "command"), (20, "", "", "command")]


def test_temperature_and_friction_reach_the_devkit_timeline(devkit_and_fingertac, tmp_path):
    emulators, manager = devkit_and_fingertac
    devkit = emulators["devkit"]
    snap = {d["name"]: d for d in manager.snapshot()["devices"]}
    assert snap["devkit"]["identity"]["model"] == "devkit" and snap["devkit"]["identity"]["caps"] == 0x37
    # at rest the encoder holds skin temperature and no friction (devices/encoder.py)
    wait_for(lambda: any(e.temperature_c == NEUTRAL_SKIN_C and e.friction == 0.0 for e in devkit.snapshot_edges()),
             1.0, "the resting layers never arrived")

    refusals = manager.submit((Temperature(celsius=40), Friction(coefficient=0.8), Texture(4000)))
    assert {(r.device, r.cue, r.code) for r in refusals} == {("fingertac", "temperature", "not_displayed"),
                                                             ("fingertac", "friction", "not_displayed")}
    wait_for(lambda: any(e.temperature_c == 40.0 and e.friction == 0.8 and e.cause == "command"
                         for e in devkit.snapshot_edges()), 1.0, "temperature 40 °C and friction 0.8 never arrived")
    # the texture's scheduled toggles carry the layers along
    wait_for(lambda: any(e.mode == 3 and e.cause == "schedule" and (e.temperature_c, e.friction) == (40.0, 0.8)
                         for e in devkit.snapshot_edges()), 1.0, "no texture toggle with the new layers")
    assert all(e.temperature_c is None and e.friction is None for e in emulators["fingertac"].snapshot_edges())

    manager.submit(())

    def at_rest() -> bool:
        rows = read_timeline(tmp_path / "devkit.csv")
        return bool(rows) and (rows[-1]["mode"], rows[-1]["temperature_c"], rows[-1]["friction"]) == ("off", "32.0", "0.0")

    wait_for(at_rest, 1.5, "the devkit timeline never returned to rest")
    rows = read_timeline(tmp_path / "devkit.csv")
    assert any(r["temperature_c"] == "40.0" and r["friction"] == "0.8" and r["cause"] == "command" for r in rows)
    fingertac_rows = read_timeline(tmp_path / "fingertac.csv")
    assert all(r["temperature_c"] == "" and r["friction"] == "" for r in fingertac_rows)


def test_simulated_rig_runs_the_devkit_emulator(tmp_path):
    rig = SimulatedRig(models=("fingertac", "ferrovibe", "devkit"), directory=tmp_path)
    configs = rig.start()
    manager = DeviceManager(configs, reopen_interval_s=0.1)
    try:
        manager.start()
        wait_for(lambda: set(manager.status().values()) == {"connected"}, 3.0, "the devices never all connected")
        assert [c.profile.model for c in configs] == ["fingertac", "ferrovibe", "devkit"]
        manager.submit((Temperature(celsius=40),))
        wait_for(lambda: any(r["temperature_c"] == "40.0" for r in read_timeline(rig.timeline("devkit"))), 1.5,
                 "40 °C never reached the devkit emulator's timeline")
    finally:
        manager.stop()
        rig.stop()


def test_viestac_emulate_accepts_devkit(tmp_path):
    link = tmp_path / "devkit"
    proc = subprocess.Popen([sys.executable, "-m", "server.cli", "emulate", "devkit", "--link", str(link)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            cwd=Path(__file__).resolve().parents[2])
    try:
        assert proc.stdout.readline().startswith("devkit emulator on /dev/pts/")
        assert proc.stdout.readline().strip() == str(link)
    finally:
        proc.terminate()
        _, err = proc.communicate(timeout=5)
    assert proc.returncode == 0 and "devkit emulator stopped" in err
