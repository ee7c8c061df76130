"""Device configuration: the command-line form, TOML files, and docs/devices.md's worked example of
a lab device that speaks ASCII lines, driven end to end over a real pseudo-terminal."""

from __future__ import annotations

import os
import re
import select
import threading
import time
import tty
from pathlib import Path

import pytest

from server.core.cues import Temperature, Texture, Tilt
from devices.manager import DeviceConfig, DeviceConfigError, DeviceManager, load_device_file
from devices.profiles import ProfileError

DOC = Path(__file__).parents[2] / "docs" / "devices.md"


def doc_example() -> str:
    match = re.search(r"```toml\n(# thermotap\.toml.*?)```", DOC.read_text(), re.S)
    assert match, "docs/devices.md lost its worked example"
    return match.group(1)


@pytest.mark.parametrize("text, name, model, port", [
    ("ferrovibe@/dev/ttyUSB0", "ferrovibe", "ferrovibe", "/dev/ttyUSB0"),
    ("left=fingertac@usb:303a:1001:A1", "left", "fingertac", "usb:303a:1001:A1"),
    ("tac=fingertac@/dev/serial/by-id/usb-x=y", "tac", "fingertac", "/dev/serial/by-id/usb-x=y"),
])
def test_command_line_form(text, name, model, port):
    config = DeviceConfig.parse(text)
    assert (config.name, config.profile.model, str(config.port)) == (name, model, port)


@pytest.mark.parametrize("text, message", [
    ("ferrovibe", "expected \\[NAME=\\]MODEL@PORT"), ("ferovibe@/dev/ttyUSB0", "built-in: fingertac, ferrovibe"),
    ("ferrovibe@ttyUSB0", "ttyUSB0"), ("Big Name=ferrovibe@/dev/ttyUSB0", "device name"),
])
def test_command_line_errors_say_what_is_wrong(text, message):
    with pytest.raises(DeviceConfigError, match=message):
        DeviceConfig.parse(text)


@pytest.mark.parametrize("toml, message", [
    ("[[device]]\nport = '/dev/ttyUSB0'\n", "missing 'profile'"),
    ("[[device]]\nprofile = 'ferrovibe'\nport = '/dev/ttyUSB0'\nspeed = 9600\n", "unknown key.*speed"),
    ("[[device]]\nprofile = 'ferrovibe'\nport = '/dev/a'\n[[device]]\nprofile = 'ferrovibe'\nport = '/dev/b'\n",
     "repeated: ferrovibe"),
    ("[[device]]\nprofile = 'ferrovibe'\n", "port"),
    ("[device\n", "not valid TOML"),
    ("[rig]\n", "unknown top-level"),
    ("[[device]]\nport = '/dev/x'\n[device.profile]\nmodel = 'x'\nchannels = ['a']\ncaps = ['pulse']\n"
     "protocol = 'line'\ndimensions = { stiffness = 'vibration', macro_roughness = 'none', fine_roughness = 'none',"
     " temperature = 'none', friction = 'none' }\n[device.profile.line]\npulse = \"P {on_sec}\\n\"\noff = \"S\\n\"\n",
     "on_sec"),
    ("[[device]]\nport = '/dev/x'\n[device.profile]\nmodel = 'x'\nchannels = ['a']\ncaps = ['pulse']\n"
     "protocol = 'line'\ndimensions = { stiffness = 'vibration', macro_roughness = 'none', fine_roughness = 'none',"
     " temperature = 'none', friction = 'none' }\n[device.profile.line]\npulse = \"P {on_ms}\\n\"\n",
     "line templates for off"),
])
def test_toml_errors_name_file_table_and_key(tmp_path, toml, message):
    path = tmp_path / "rig.toml"
    path.write_text(toml)
    with pytest.raises(DeviceConfigError, match=message) as info:
        load_device_file(path)
    assert str(path) in str(info.value)


def test_the_documented_example_loads(tmp_path):
    path = tmp_path / "thermotap.toml"
    path.write_text(doc_example())
    (config,) = load_device_file(path)
    assert config.name == "thermo" and config.profile.protocol == "line"
    assert config.profile.table_row() == {"stiffness": "(!)", "macro_roughness": "(!)", "fine_roughness": "-",
                                          "temperature": "!", "friction": "-"}


class LineDevice:
    """A lab's ASCII firmware, as far as the test can tell: answers '?' and records lines."""

    def __init__(self, link: Path):
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        os.symlink(os.ttyname(self.slave), link)
        self.lines: list[str] = []
        self._stop = False
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self):
        buffer = b""
        while not self._stop:
            if not select.select([self.master], [], [], 0.05)[0]:
                continue
            buffer += os.read(self.master, 1024)
            *lines, buffer = buffer.split(b"\n")
            for line in lines:
                text = line.decode()
                self.lines.append(text)
                if text == "?":
                    os.write(self.master, b"THERMOTAP v1\n")

    def close(self):
        self._stop = True
        self._thread.join()
        os.close(self.master)
        os.close(self.slave)


def test_a_line_device_connects_without_code(tmp_path):
    (config,) = load_device_file(_example_file(tmp_path))
    device = LineDevice(tmp_path / "ttyACM0")
    manager = DeviceManager([config], reopen_interval_s=0.1)
    manager.start()
    try:
        deadline = time.monotonic() + 3
        while manager.status()["thermo"] != "connected":
            assert time.monotonic() < deadline, "the hello/hello_reply handshake did not complete"
            time.sleep(0.01)
        manager.submit((Tilt(90, 70), Temperature(34.5)))
        time.sleep(0.2)
        refusals = manager.submit((Texture(2000),))
        time.sleep(0.2)
    finally:
        manager.stop()
        device.close()
    assert device.lines[0] == "?"
    assert "V 70 1 0" in device.lines, device.lines  # tilt as vibration at its magnitude (macro-roughness (!))
    assert "T 34.5" in device.lines
    assert sorted(device.lines[-2:]) == ["S", "T 32"], "a refused texture leaves the device at rest"
    (refusal,) = refusals
    assert refusal.code == "not_displayed" and refusal.reason.startswith("thermo (thermotap) cannot show the texture")


def _example_file(tmp_path: Path) -> Path:
    path = tmp_path / "thermotap.toml"
    path.write_text(doc_example().replace('"/dev/ttyACM0"', f'"{tmp_path / "ttyACM0"}"'))
    return path


def test_a_profile_error_is_a_value_error_for_the_cli():
    assert issubclass(DeviceConfigError, ValueError) and issubclass(ProfileError, ValueError)
