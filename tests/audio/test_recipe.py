"""docs/devices.md "An audio channel": its rig file, read as written (only the JACK server's name
swapped for this test's), runs against a JACK dummy server like `viestac emulate audio`'s."""

import re
import time
from pathlib import Path

from devices.manager import DeviceManager, load_device_file
from server.core.cues import Texture, Tilt

DOC = Path(__file__).resolve().parents[2] / "docs" / "devices.md"


def recipe_rig_file() -> str:
    text = DOC.read_text(encoding="utf-8")
    return next(b for b in re.findall(r"```toml\n(.*?)```", text, re.S) if b.startswith("# coil-rig.toml"))


def test_the_audio_recipe_rig_file_runs(jack_server, tmp_path):
    rig = tmp_path / "coil-rig.toml"
    text = recipe_rig_file()
    assert 'jack_server = "viestac-lab"' in text
    rig.write_text(text.replace('"viestac-lab"', f'"{jack_server.name}"'))
    (config,) = load_device_file(rig)
    assert config.profile.model == "audio" and config.profile.channels == ("coil",)
    assert config.audio.channels[0].calibration.peak_for(250.0, 1.0) == 19.0
    manager = DeviceManager([config])
    manager.start()
    try:
        deadline = time.monotonic() + 60
        while manager.status()["coil"] != "connected":
            assert time.monotonic() < deadline, manager.devices["coil"].driver.last_error
            time.sleep(0.05)
        assert manager.submit((Texture(period_us=4000.0, duty=0.5, intensity_pct=80.0),)) == ()
        channel = manager.snapshot()["devices"][0]["audio"]["channels"][0]
        assert channel["shape"] == "texture" and channel["frequency_hz"] == 250.0 and channel["drive"] == 0.8
        (refusal,) = manager.submit((Tilt(direction_deg=0.0, magnitude_pct=100.0),))
        assert refusal.code == "not_displayed"
    finally:
        manager.stop()
