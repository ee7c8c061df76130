"""The browser device's profile and encoder (devices/browser.py): what a WebXR controller or a gamepad
can show (amplitude and duration), refused with a reason otherwise; its configuration and the rig."""

from __future__ import annotations

import pytest

from devices.browser import MAX_EFFECT_MS, BrowserConfigError, BrowserEncoder, check_configs
from devices.capability import check
from devices.manager import DeviceConfig, DeviceConfigError
from devices.profiles import BROWSER, DeviceProfile, ProfileError, profile_by_model
from devices.rig import SimulatedRig
from scenarios import registry
from server.core.cues import Friction, PulseTrain, Stiffness, Stop, Temperature, Texture, Tilt, Vibration


def encode(*cues, tick=7):
    return BrowserEncoder().encode(cues, tick)


def test_a_tilt_is_its_magnitude_and_a_vibration_its_intensity():
    assert encode(Tilt(direction_deg=30.0, magnitude_pct=60.0)).drive.to_wire() == [0.6, 0.0, 0.0, 0.0, 7]
    assert encode(Vibration(intensity_pct=80.0)).drive.to_wire() == [0.8, 0.0, 0.0, 0.0, 7]
    assert encode().drive.value == 0 and encode(Vibration(80.0), Stop()).drive.value == 0


def test_pulse_trains_and_stiffness_keep_their_timing_and_a_timed_stimulus_its_length():
    assert encode(PulseTrain(t_on_ms=100.0, t_off_ms=200.0, intensity_pct=50.0)).drive.to_wire() == \
        [0.5, 100.0, 200.0, 0.0, 7]
    soft = encode(Stiffness(k_n_per_m=100.0, relative=0.0)).drive
    assert (soft.value, soft.on_ms, soft.off_ms) == (1.0, 50.0, 950.0)  # 1 Hz bursts of 50 ms
    assert encode(Vibration(40.0, duration_ms=500.0)).drive.to_wire() == [0.4, 0.0, 0.0, 500.0, 7]


@pytest.mark.parametrize("cue, code, words", [
    (Vibration(80.0, carrier_hz=250.0), "no_capability", "not a carrier frequency (250 Hz asked)"),
    (PulseTrain(50.0, 50.0, 80.0, duration_ms=MAX_EFFECT_MS + 1), "out_of_range", "at most 5 s"),
    (Texture(period_us=4000.0), "not_displayed", "does not display fine-roughness"),
    (Temperature(celsius=34.0), "not_displayed", "does not display temperature"),
    (Friction(coefficient=0.5), "not_displayed", "does not display friction"),
])
def test_what_it_cannot_show_is_refused_with_a_reason_and_plays_nothing(cue, code, words):
    encoding = encode(cue)
    (refusal,) = encoding.refusals
    assert refusal.code == code and words in refusal.reason and refusal.reason.startswith("browser (browser) cannot")
    assert encoding.drive.value == 0


def test_the_capability_check_refuses_texture_and_allows_contact_angle_and_stiffness():
    profiles = {"browser": profile_by_model("browser")}
    for name, ok in (("texture", False), ("friction-temperature", False), ("contact-angle", True), ("stiffness", True)):
        cls = registry.resolve(name).factory
        report = check(cls.id, tuple(cls.REQUIRES), profiles)
        assert report.ok is ok, report.message
    cls = registry.resolve("texture").factory
    assert "cannot show the texture cue: its profile does not display fine-roughness" in \
        check(cls.id, tuple(cls.REQUIRES), profiles).message


def test_the_profile_states_its_limits():
    assert BROWSER.carrier_hz == 0 and BROWSER.caps == {"pulse", "continuous"} and BROWSER.protocol == "browser"
    with pytest.raises(ProfileError, match="pulse and continuous patterns only"):
        DeviceProfile.from_dict({**BROWSER.to_table(), "caps": ["pulse", "continuous", "tilt"]})


def test_configuration_a_browser_device_has_no_port_and_sits_on_the_primary_point():
    config = DeviceConfig.from_dict({"name": "pad", "profile": "browser"}, "rig device #1")
    assert config.port is None and config.where == "browser:/ws"
    with pytest.raises(DeviceConfigError, match="only name, profile and finger"):
        DeviceConfig.from_dict({"profile": "browser", "port": "/dev/ttyUSB0"}, "rig device #1")
    with pytest.raises(DeviceConfigError, match="has no port"):
        DeviceConfig.parse("browser@/dev/ttyUSB0")
    with pytest.raises(BrowserConfigError, match="at most one browser device"):
        check_configs([config, DeviceConfig.from_dict({"name": "pad2", "profile": "browser"}, "#2")])
    with pytest.raises(BrowserConfigError, match="follows the primary point"):
        check_configs([DeviceConfig.from_dict({"profile": "browser", "finger": "left.index.tip"}, "#1")])


def test_the_simulated_rig_takes_a_browser_device_without_an_emulator(tmp_path):
    rig = SimulatedRig(("browser",), directory=tmp_path)
    try:
        (config,) = rig.start()
        assert (config.name, config.port, config.profile.model) == ("browser", None, "browser")
        assert rig.procs == {} and list(tmp_path.iterdir()) == []
    finally:
        rig.stop()
