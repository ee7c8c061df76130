"""Which finger each device sits on: the rig file's `finger`, `serve --finger NAME=POINT`, and the
tools the loop makes of them (docs/devices.md "Several fingers")."""

from __future__ import annotations

import pytest

from devices.manager import DeviceConfig, DeviceConfigError, load_device_file, rig_points, with_fingers
from devices.ports import PortSpec
from devices.profiles import profile_by_model
from server.cli import _fingers
from server.config import Settings
from server.core.points import PRIMARY_POINT
from server.loop.process import LoopConfig

TWO = """
[[device]]
name = "index"
profile = "ferrovibe"
port = "/dev/ttyUSB0"

[[device]]
name = "thumb"
profile = "fingertac"
port = "/dev/ttyUSB1"
finger = "right.thumb.tip"
"""


def test_a_rig_file_puts_each_device_on_its_finger_the_primary_by_default(tmp_path):
    path = tmp_path / "rig.toml"
    path.write_text(TWO)
    index, thumb = load_device_file(path)
    assert (index.finger, thumb.finger) == (PRIMARY_POINT, "right.thumb.tip")
    assert rig_points([index.finger, thumb.finger]) == ("right.thumb.tip",)


def test_a_finger_that_is_not_a_point_name_is_refused_naming_the_device(tmp_path):
    path = tmp_path / "rig.toml"
    path.write_text(TWO.replace("right.thumb.tip", "thumb"))
    with pytest.raises(DeviceConfigError, match="device thumb: finger: 'thumb' is not a tracked point name"):
        load_device_file(path)


def test_serve_finger_overrides_the_file_and_names_only_known_devices():
    configs = [DeviceConfig("ferrovibe", profile_by_model("ferrovibe"), PortSpec.parse("/dev/null")),
               DeviceConfig("fingertac", profile_by_model("fingertac"), PortSpec.parse("/dev/null"))]
    moved = with_fingers(configs, {"fingertac": "right.thumb.tip"})
    assert [c.finger for c in moved] == [PRIMARY_POINT, "right.thumb.tip"]
    with pytest.raises(DeviceConfigError, match="--finger names no configured device: devkit"):
        with_fingers(configs, {"devkit": "right.thumb.tip"})


def test_the_simulated_rig_fingers_reach_the_loop_as_its_tools():
    settings = Settings(fingers=_fingers(["ferrovibe=right.index.tip", "fingertac=right.thumb.tip"]))
    assert settings.device_fingers() == {"fingertac": "right.thumb.tip", "ferrovibe": PRIMARY_POINT}
    config = settings.loop_config()
    assert config.rig == ("right.thumb.tip",)
    assert LoopConfig.from_json(config.to_json()).rig == ("right.thumb.tip",), "the loop process gets it"
    assert Settings().loop_config().rig == (), "by default one tool, as before"


@pytest.mark.parametrize("fingers, message", [
    (["devkit=right.thumb.tip"], "--finger names no device: devkit"),
    (["fingertac=thumb"], "--finger fingertac=thumb: 'thumb' is not a tracked point name"),
])
def test_settings_refuse_a_bad_finger_at_start(fingers, message):
    with pytest.raises(ValueError, match=message):
        Settings(fingers=_fingers(fingers))


def test_a_finger_flag_without_equals_sign_is_refused():
    with pytest.raises(ValueError, match="expected NAME=POINT"):
        _fingers(["fingertac"])
