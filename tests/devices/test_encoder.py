"""Profiles and the cue encoder: what each device shows, and what it refuses (with the reason)."""

import pytest

from server.core.cues import Friction, PulseTrain, Stop, Temperature, Texture, Tilt, Vibration
from devices.encoder import CueEncoder
from devices.messages import ALL_CHANNELS, PatternMode, SetPattern, SetTemperature, SetTilt
from devices.profiles import FERROVIBE, FINGERTAC, DeviceProfile, Display, ProfileError, profile_by_model

FV, FT = CueEncoder(FERROVIBE), CueEncoder(FINGERTAC)


def test_profiles_follow_table_2_2_notation():
    assert FINGERTAC.table_row() == {"stiffness": "(!)", "macro_roughness": "-", "fine_roughness": "(!)",
                                     "temperature": "-", "friction": "-"}
    assert FERROVIBE.table_row() == {"stiffness": "(!)", "macro_roughness": "!", "fine_roughness": "!",
                                     "temperature": "-", "friction": "-"}
    assert FINGERTAC.carrier_hz == 235 and len(FINGERTAC.channels) == 2 and len(FERROVIBE.channels) == 1


def test_no_cue_means_every_layer_off():
    assert FV.encode(()).commands == {"pattern": SetPattern.off(), "tilt": SetTilt.flat()}
    assert FT.encode(()).commands == {"pattern": SetPattern.off()}
    assert FV.encode(()).refusals == ()


def test_tilt_on_ferrovibe_is_direct_in_centidegrees():
    enc = FV.encode((Tilt(90.0, 100.0),))
    assert enc.commands["tilt"] == SetTilt(ALL_CHANNELS, 9000, 100)
    assert enc.commands["pattern"] == SetPattern.off() and enc.refusals == ()


def test_tilt_on_fingertac_is_refused_with_the_documented_reason():
    enc = FT.encode((Tilt(90.0, 100.0),))
    assert enc.commands == {"pattern": SetPattern.off()}, "a refused cue sends nothing for it"
    (refusal,) = enc.refusals
    assert (refusal.code, refusal.cue, refusal.dimension) == ("not_displayed", "tilt", "macro_roughness")
    assert refusal.reason == ("fingertac (fingertac) cannot show the tilt cue: "
                              "its profile does not display macro-roughness (Table 2.2: -)")


@pytest.mark.parametrize("period_us", [2000, 3000, 4000, 5000, 6000])
def test_texture_direct_on_ferrovibe_is_half_on_half_off(period_us):
    pattern = FV.encode((Texture(period_us, 0.5, 100),)).commands["pattern"]
    assert (pattern.mode, pattern.on_us, pattern.off_us, pattern.carrier_hz) == (PatternMode.TEXTURE, period_us // 2,
                                                                                period_us // 2, 0)


def test_texture_on_fingertac_is_vibration_at_the_texture_frequency():
    pattern = FT.encode((Texture(3000, 0.5, 80),)).commands["pattern"]
    assert (pattern.mode, pattern.carrier_hz, pattern.intensity) == (PatternMode.CONTINUOUS, 333, 80)


def test_pulse_train_is_sent_in_microseconds():
    pattern = FT.encode((PulseTrain(50, 200, 100),)).commands["pattern"]
    assert (pattern.mode, pattern.on_us, pattern.off_us, pattern.intensity) == (PatternMode.PULSE, 50_000, 200_000, 100)


def test_two_cues_for_one_layer_refuse_the_second_as_a_conflict():
    enc = FV.encode((Texture(4000), PulseTrain(50, 200)))
    assert enc.commands["pattern"].mode == PatternMode.TEXTURE
    assert [r.code for r in enc.refusals] == ["conflict"] and "already shows the texture" in enc.refusals[0].reason


def test_tilt_and_texture_together_use_both_ferrovibe_layers():
    enc = FV.encode((Tilt(270, 60), Texture(2000)))
    assert enc.commands["tilt"].direction_cdeg == 27000 and enc.commands["pattern"].mode == PatternMode.TEXTURE


@pytest.mark.parametrize("cue", [Temperature(34.0), Friction(0.4)])
def test_temperature_and_friction_are_refused_by_both_devices(cue):
    for encoder in (FV, FT):
        (refusal,) = encoder.encode((cue,)).refusals
        assert refusal.code == "not_displayed" and refusal.cue == cue.kind


def test_stop_turns_everything_off_and_refuses_nothing():
    enc = FV.encode((Tilt(90, 100), Temperature(40), Stop()))
    assert enc.commands == FV.encode(()).commands and enc.refusals == ()


def thermal_profile(**overrides) -> DeviceProfile:
    data = {"model": "thermotap", "channels": ["finger"], "caps": ["pulse", "continuous", "temperature"],
            "dimensions": {"stiffness": "vibration", "macro_roughness": "vibration", "fine_roughness": "none",
                           "temperature": "direct", "friction": "none"}}
    return DeviceProfile.from_dict({**data, **overrides})


def test_a_custom_profile_shows_temperature_and_tilt_as_vibration():
    encoder = CueEncoder(thermal_profile(), "thermo")
    assert encoder.encode(()).commands["temperature"] == SetTemperature(ALL_CHANNELS, 3200)  # neutral skin
    enc = encoder.encode((Tilt(90, 70), Temperature(34.5)))
    assert enc.commands["temperature"] == SetTemperature(ALL_CHANNELS, 3450)
    assert enc.commands["pattern"] == SetPattern.continuous(ALL_CHANNELS, 70)
    (refusal,) = encoder.encode((Texture(2000),)).refusals
    assert refusal.reason.startswith("thermo (thermotap) cannot show the texture cue")


def test_a_device_without_vibration_refuses_pulse_trains():
    profile = thermal_profile(caps=["temperature"], dimensions={
        "stiffness": "none", "macro_roughness": "none", "fine_roughness": "none", "temperature": "direct",
        "friction": "none"})
    (refusal,) = CueEncoder(profile).encode((PulseTrain(),)).refusals
    assert refusal.code == "no_capability" and "pulse-train" in refusal.reason
    assert CueEncoder(profile).encode((Vibration(),)).refusals[0].code == "no_capability"


@pytest.mark.parametrize("overrides, message", [
    ({"model": "Thermo Tap"}, "lower-case"),
    ({"caps": ["pulse", "smell"]}, "unknown caps"),
    ({"dimensions": {"stiffness": "direct"}}, "dimensions must be exactly"),
    ({"dimensions": {"stiffness": "vibration", "macro_roughness": "none", "fine_roughness": "none",
                     "temperature": "vibration", "friction": "none"}}, "temperature has no vibration encoding"),
    ({"caps": ["pulse"]}, "temperature shown directly needs the 'temperature' cap"),
    ({"dimensions": {"stiffness": "loud", "macro_roughness": "none", "fine_roughness": "none",
                     "temperature": "none", "friction": "none"}}, "loud"),
    ({"protocol": "line"}, "needs \\[line\\] templates"),
    ({"colour": "red"}, "unknown key"),
])
def test_bad_profiles_are_refused_with_the_key_named(overrides, message):
    with pytest.raises(ProfileError, match=message):
        thermal_profile(**overrides)


def test_identity_overrides_the_profile():
    reduced = FERROVIBE.with_identity(channels=1, caps=frozenset({"pulse", "continuous", "texture"}), carrier_hz=200,
                                      firmware="1.1.0")
    assert reduced.dimensions["macro_roughness"] is Display.NONE and reduced.carrier_hz == 200
    assert CueEncoder(reduced).encode((Tilt(0, 100),)).refusals[0].code == "not_displayed"


def test_unknown_model_names_the_built_ins():
    with pytest.raises(ProfileError, match="fingertac, ferrovibe"):
        profile_by_model("ferovibe")
