"""The audio device's configuration (devices/audio/config.py) and cue mapping, without a server:
the rig file's table, PortAudio's lists passed in, the calibration's arithmetic."""

import pytest

from devices.audio.config import AudioChannel, AudioConfig, AudioConfigError, Calibration
from devices.audio.mapping import AudioCueEncoder, stimuli_for
from devices.manager import DeviceConfig, DeviceConfigError
from devices.profiles import AUDIO
from server.core.cues import PulseTrain, Stop, Temperature, Texture, Tilt, Vibration

HOSTAPIS = [{"name": "ALSA"}, {"name": "JACK Audio Connection Kit"}]
DEVICES = [{"name": "HDA Intel PCH: ALC3246 Analog (hw:0,0)", "hostapi": 0, "max_output_channels": 2},
           {"name": "system", "hostapi": 1, "max_output_channels": 8},
           {"name": "MOTU UltraLite", "hostapi": 1, "max_output_channels": 0}]
CAL = Calibration("m/s^2", ((20.0, 1.0, 4.0), (250.0, 0.5, 9.5), (250.0, 1.0, 19.0), (1000.0, 1.0, 6.0)))


def cfg(**kw) -> AudioConfig:
    base = dict(output="system", host_api="JACK", channels=(AudioChannel("coil", 1),))
    base.update(kw)
    return AudioConfig(**base)


def test_the_output_is_found_by_name_and_host_api_never_by_index():
    assert cfg().check_output(DEVICES, HOSTAPIS) == 1
    assert cfg(output="ALC3246", host_api="alsa").check_output(DEVICES, HOSTAPIS) == 0


@pytest.mark.parametrize("config, message", [
    (cfg(output="Focusrite"), "unknown output device 'Focusrite' on JACK; its outputs: 'system'"),
    (cfg(host_api="ASIO"), "unknown host API 'ASIO': PortAudio here has 'ALSA', 'JACK Audio Connection Kit'"),
    (cfg(channels=(AudioChannel("coil", 9),)), "channel 9 (coil) is beyond the 8 output channels of 'system'"),
])
def test_a_bad_output_is_refused_by_name(config, message):
    with pytest.raises(AudioConfigError) as err:
        config.check_output(DEVICES, HOSTAPIS)
    assert message in str(err.value)


def test_the_calibration_converts_both_ways_and_must_cover_the_range():
    assert CAL.peak_for(250.0, 0.25) == pytest.approx(4.75)
    assert CAL.peak_for(250.0, 0.75) == pytest.approx(14.25)
    assert CAL.peak_for(135.0, 1.0) == pytest.approx((4.0 + 19.0) / 2)  # halfway in frequency
    assert CAL.drive_for(250.0, 10.0) == pytest.approx(0.5 + 0.5 * 0.5 / 9.5)
    assert CAL.peak_for(250.0, CAL.drive_for(250.0, 12.3)) == pytest.approx(12.3)
    ok = cfg(channels=(AudioChannel("coil", 1, frequency_hz=(20.0, 1000.0), calibration=CAL),))
    assert ok.check() == []
    wide = cfg(channels=(AudioChannel("coil", 1, frequency_hz=(20.0, 2000.0), calibration=CAL),))
    assert wide.check() == ["the calibration of coil covers 20-1000 Hz, not its declared range 20-2000 Hz"]
    with pytest.raises(AudioConfigError, match="must rise with the drive"):
        Calibration("m", ((250.0, 0.5, 2.0), (250.0, 1.0, 1.0)))


def test_the_rig_table_is_read_and_its_mistakes_named():
    table = {"name": "coil", "profile": "audio", "audio": {
        "output": "system", "host_api": "JACK", "sample_rate": 48000, "block": 64,
        "channel": [{"actuator": "left", "channel": 1, "gain": 0.5}, {"actuator": "right", "channel": 2}]}}
    config = DeviceConfig.from_dict(table, "rig device #1")
    assert config.port is None and config.where == "audio:system@JACK"
    assert config.profile.channels == ("left", "right") and config.audio.outputs == 2
    bad = {**table, "audio": {**table["audio"], "block": 8}}
    with pytest.raises(DeviceConfigError, match="rig device #1.audio: audio: block must be 32..1024"):
        DeviceConfig.from_dict(bad, "rig device #1")
    with pytest.raises(DeviceConfigError, match="an audio device has no port"):
        DeviceConfig.from_dict({**table, "port": "/dev/ttyUSB0"}, "rig device #1")
    with pytest.raises(DeviceConfigError, match="described in a rig file"):
        DeviceConfig.parse("audio@/dev/ttyUSB0")
    with pytest.raises(DeviceConfigError, match="goes with an \\[device.audio\\] table"):
        DeviceConfig.from_dict({"name": "x", "profile": "audio", "port": "/dev/ttyUSB0"}, "rig device #2")


def test_every_cue_kind_maps_to_a_waveform_or_a_refusal():
    config = cfg(channels=(AudioChannel("coil", 1, gain=0.8, peak=0.6, frequency_hz=(20.0, 500.0)),))
    encoder = AudioCueEncoder(AUDIO, "coil", config)

    def stimulus(cue):
        encoding = encoder.encode((cue,))
        return stimuli_for(tuple(encoding.commands.values()), config, AUDIO.carrier_hz)[0], encoding.refusals

    s, r = stimulus(Vibration(intensity_pct=50.0))
    assert (s.shape, s.amplitude, s.frequency_hz, r) == ("sine", 0.4, 250.0, ())
    s, _ = stimulus(Vibration(intensity_pct=100.0, carrier_hz=100.0))
    assert (s.amplitude, s.frequency_hz) == (0.6, 100.0)  # capped at the channel's peak
    s, _ = stimulus(PulseTrain(t_on_ms=50.0, t_off_ms=200.0, intensity_pct=100.0))
    assert (s.shape, s.on_s, s.off_s) == ("pulse", 0.05, 0.2)
    s, _ = stimulus(Texture(period_us=4000.0, duty=0.25, intensity_pct=50.0))
    assert (s.shape, s.frequency_hz, s.duty, s.amplitude) == ("texture", 250.0, 0.25, 0.4)
    for cue, code in ((Tilt(), "not_displayed"), (Temperature(), "not_displayed"),
                      (Vibration(carrier_hz=800.0), "out_of_range")):
        s, r = stimulus(cue)
        assert s.silent and [x.code for x in r] == [code]
    s, r = stimulus(Stop())
    assert s.silent and r == ()
