"""The simulated rig plays an audio tactor through the audio path (server/simulate/virtual_device.py
VirtualAudioDevice): the audio encoder and cue → stimulus mapping, the synth's gating as edges; a
study whose tasks name a device outside the thesis's rig gets that device in its rig."""

from __future__ import annotations

from pathlib import Path

import pytest

from devices.profiles import profile_by_model
from server.core.cues import PulseTrain, Tilt, Vibration
from server.experiment.study import load_study
from server.simulate.study_run import RIG, rig_for
from server.simulate.virtual_device import VirtualAudioDevice, VirtualDevice, virtual_device

ROOT = Path(__file__).resolve().parents[2]


def test_a_vibration_is_on_from_its_hand_over_and_off_when_the_cue_ends():
    device = virtual_device("audio", profile_by_model("audio"))
    assert isinstance(device, VirtualAudioDevice) and device.status == "connected"
    device.run_until(0.1)
    device.submit((Vibration(intensity_pct=40, carrier_hz=160),))
    device.run_until(0.5)
    assert device.feel.continuous(0.5) and device.feel.channels[0].intensity == 40
    assert device.edges[-1].carrier_hz == 160 and device.edges[-1].t_us == 100_000
    device.submit(())
    device.run_until(0.6)
    assert not device.feel.channels[0].on and device.edges[-1].t_us == 500_000


def test_a_pulse_train_gates_on_and_off_at_its_own_times():
    device = virtual_device("audio", profile_by_model("audio"))
    device.submit((PulseTrain(t_on_ms=20, t_off_ms=80, intensity_pct=100),))
    device.run_until(0.35)
    onsets = [e.t_us for e in device.edges if e.gate]
    offsets = [e.t_us for e in device.edges if not e.gate]
    assert onsets == [0, 100_000, 200_000, 300_000] and offsets == [20_000, 120_000, 220_000, 320_000]
    assert device.feel.pulse_interval_s(0.35) == pytest.approx(0.1)


def test_what_an_audio_tactor_cannot_show_is_refused_as_on_a_real_rig():
    device = virtual_device("audio", profile_by_model("audio"))
    device.submit((Tilt(direction_deg=90),))
    assert device.refusals and not device.feel.channels[0].on
    device.submit((Vibration(carrier_hz=1500),))  # outside the channel's 20-1000 Hz
    assert device.refusals[0].code == "out_of_range"


def test_a_studys_own_devices_join_the_simulated_rig():
    assert isinstance(virtual_device("fingertac", profile_by_model("fingertac")), VirtualDevice)
    assert rig_for(load_study(ROOT / "studies" / "thesis-2021.toml")) == RIG
    assert rig_for(load_study(ROOT / "studies" / "battery-audio.toml")) == (*RIG, "audio")
    assert rig_for(load_study(ROOT / "studies" / "battery-devkit.toml")) == (*RIG, "devkit")
