"""Audio devices against a real audio server: JACK with its dummy driver at 48 kHz, 64-frame
periods; ViESTac's stream goes through PortAudio's JACK host API (in the audio worker process) and
a JACK capture client records what arrives at the output ports."""

import math
import subprocess
import sys
import time

import numpy as np
import pytest

from devices.audio.capture import Capture
from devices.audio.config import AudioChannel, AudioConfig, Calibration
from devices.audio.device import AudioDevice
from devices.audio.synth import Stimulus
from devices.manager import DeviceConfig, DeviceManager
from devices.profiles import AUDIO
from dataclasses import replace
from server.core.cues import PulseTrain, Texture, Tilt, Vibration

RATE = 48_000
CALIBRATION = Calibration("m/s^2", ((20.0, 1.0, 4.0), (250.0, 0.5, 9.5), (250.0, 1.0, 19.0), (1000.0, 1.0, 6.0)))


def wait_for(predicate, timeout_s: float = 60.0, what: str = "condition"):  # a busy 2-core machine
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.02)


def config(server, **overrides) -> AudioConfig:
    base = dict(output="system", host_api="JACK", jack_server=server.name, sample_rate=RATE, block=64, ramp_ms=2.0,
                channels=(AudioChannel("coil", 1, calibration=CALIBRATION),))
    base.update(overrides)
    return AudioConfig(**base)


def connected_device(server, capture, cfg=None) -> AudioDevice:
    device = AudioDevice("coil", cfg or config(server), AUDIO.carrier_hz)
    device.start()
    wait_for(lambda: device.status == "connected", what=f"the device to connect ({device.last_error})")
    wait_for(capture.connected, what="the capture to follow ViESTac's ports")
    return device


def frequency(x: np.ndarray) -> float:
    n = 16 * len(x)
    spectrum = np.log(np.abs(np.fft.rfft(x * np.hanning(len(x)), n)) + 1e-30)
    k = int(np.argmax(spectrum))
    a, b, c = spectrum[k - 1:k + 2]
    return float((k + 0.5 * (a - c) / (a - 2 * b + c)) * RATE / n)


def test_portaudio_here_lists_the_jack_host_api(jack_server):
    code = ("from devices.audio.shell import portaudio; sd = portaudio(%r); "
            "print([a['name'] for a in sd.query_hostapis()])" % jack_server.name)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert "JACK Audio Connection Kit" in out.stdout, out.stdout + out.stderr


def recording(device, capture, stimulus_at, length: int) -> np.ndarray:
    """Play `stimulus_at(start sample)` a little ahead of the worker's clock and record it."""
    wait_for(lambda: device.next_sample > 0, what="the worker's sample clock")
    recorded_from = capture.frames
    device.play("coil", stimulus_at(device.next_sample + 9600))
    wait_for(lambda: capture.frames > recorded_from + 9600 + length + 4 * 4800, what="the recording")
    return capture.read(recorded_from)[:, 0].astype(np.float64)


def test_a_250_hz_100_ms_stimulus_arrives_at_the_port_as_planned(jack_server):
    capture = Capture(jack_server.name, 1).start()
    device = connected_device(jack_server, capture)
    try:
        wanted = 10.0  # m/s² peak, asked for in physical units
        drive = CALIBRATION.drive_for(250.0, wanted)
        planned = round(0.100 * RATE)
        x = recording(device, capture, lambda start: Stimulus("sine", drive, 250.0, start=start, duration=planned),
                      planned)
        on = np.nonzero(x)[0]
        assert len(on) > 0, "nothing arrived"
        first, last = on[0], on[-1]
        # the carrier starts at phase 0 (its first sample is sin 0 = 0): plan − 1 … plan nonzero samples
        assert abs((last - first + 1) - planned) <= 1
        steady = x[first + 200:last - 200]
        assert frequency(steady) == pytest.approx(250.0, abs=0.5)
        peak = np.max(np.abs(steady))
        assert CALIBRATION.peak_for(250.0, peak) == pytest.approx(wanted, rel=0.01)
        # no step larger than the envelope allows: the carrier's own slope plus one ramp step
        ramp = round(0.002 * RATE)
        allowed = 2 * math.pi * 250.0 * drive / RATE + drive / ramp + 1e-6
        steps = np.abs(np.diff(x[first - 10:last + 10]))
        assert steps.max() <= allowed
        assert abs(x[first]) <= drive / ramp + 1e-6 and abs(x[last]) <= drive / ramp + 1e-6
    finally:
        device.stop()
        capture.stop()


def test_every_cue_kind_becomes_a_waveform_or_a_refusal(jack_server):
    capture = Capture(jack_server.name, 2).start()
    cfg = config(jack_server, channels=(AudioChannel("coil", 1, gain=0.8, frequency_hz=(20.0, 500.0)),
                                        AudioChannel("coil2", 2, peak=0.3)))
    profile = replace(AUDIO, channels=cfg.actuators)
    manager = DeviceManager([DeviceConfig(name="coil", profile=profile, port=None, audio=cfg)])
    manager.start()
    device = manager.devices["coil"].driver
    try:
        wait_for(lambda: device.status == "connected", what=f"the device to connect ({device.last_error})")
        wait_for(capture.connected, what="the capture to follow ViESTac's ports")

        def recorded(cues, seconds=0.3):
            manager.submit(cues)
            time.sleep(0.05)  # past the ramp
            start = capture.frames
            wait_for(lambda: capture.frames > start + seconds * RATE, what="the recording")
            return capture.read(start, start + int(seconds * RATE)).astype(np.float64)

        x = recorded((Vibration(intensity_pct=50.0, carrier_hz=200.0),))
        assert frequency(x[:, 0]) == pytest.approx(200.0, abs=0.5)
        assert np.max(np.abs(x[:, 0])) == pytest.approx(0.5 * 0.8, rel=0.01)     # intensity · gain
        assert np.max(np.abs(x[:, 1])) == pytest.approx(0.3, rel=0.01)           # its peak limit
        x = recorded((PulseTrain(t_on_ms=20.0, t_off_ms=30.0, intensity_pct=100.0),), 0.5)
        gate = (np.abs(x[:, 0]) > 0).reshape(-1, 240).any(axis=1)  # 5 ms windows
        assert 0.3 < gate.mean() < 0.6  # on ~20 of every 50 ms (plus ramps)
        assert frequency(x[:, 0] * (np.abs(x[:, 0]) > 0)) == pytest.approx(AUDIO.carrier_hz, abs=2.0)
        x = recorded((Texture(period_us=8000.0, duty=0.5, intensity_pct=100.0),))
        assert frequency(x[:, 0]) == pytest.approx(125.0, abs=0.5)
        assert abs(np.mean(x[:, 0])) < 0.02
        manager.submit((Tilt(direction_deg=90.0, magnitude_pct=100.0),))
        assert [r.code for r in manager.refusals] == ["not_displayed"]
        x = recorded((Vibration(intensity_pct=50.0, carrier_hz=800.0),))  # beyond coil's 500 Hz
        assert [r.code for r in manager.refusals] == ["out_of_range"]
        assert "800 Hz is outside coil's 20-500 Hz" in manager.refusals[0].reason
        x = recorded(())
        assert not np.any(x)
    finally:
        manager.stop()
        capture.stop()


def test_bad_configuration_is_refused_by_name_and_the_rest_of_the_rig_runs(jack_server):
    good = config(jack_server)
    bad = {
        "ghost": (config(jack_server, output="no-such-interface"), "unknown output device 'no-such-interface'"),
        "beyond": (config(jack_server, channels=(AudioChannel("coil", 5),)), "channel 5 (coil) is beyond the 2 output"),
        "rate": (config(jack_server, sample_rate=44_100), "unsupported sample rate 44100 Hz"),
        "uncal": (config(jack_server, channels=(AudioChannel("coil", 1, frequency_hz=(10.0, 1200.0),
                                                             calibration=CALIBRATION),)),
                  "calibration of coil covers 20-1000 Hz, not its declared range 10-1200 Hz"),
    }
    configs = [DeviceConfig(name=name, profile=AUDIO, port=None, audio=cfg) for name, (cfg, _) in bad.items()]
    configs.append(DeviceConfig(name="good", profile=AUDIO, port=None, audio=good))
    manager = DeviceManager(configs)
    manager.start()
    try:
        wait_for(lambda: manager.status()["good"] == "connected", 60.0,
                 what=f"the good device ({manager.devices['good'].driver.last_error})")
        for name, (_, message) in bad.items():
            device = manager.devices[name].driver
            wait_for(lambda device=device: device.status == "refused", what=f"{name} refused")
            assert message in device.last_error, device.last_error
            assert message in manager.snapshot()["devices"][list(bad).index(name)]["last_error"]
        assert manager.status()["good"] == "connected"
    finally:
        manager.stop()


def test_the_audio_server_dying_disconnects_and_the_device_comes_back(jack_server):
    capture = Capture(jack_server.name, 1).start()
    device = connected_device(jack_server, capture)
    capture.stop()
    try:
        device.set_commands(())
        device.play("coil", Stimulus("sine", 0.5, 250.0))
        jack_server.kill()
        wait_for(lambda: device.status == "disconnected", 2.0, "disconnected after the server died")
        assert device.disconnects == 1
        jack_server.start()
        wait_for(lambda: device.status == "connected", 20.0, "connected again")
        capture = Capture(jack_server.name, 1).start()
        wait_for(capture.connected, what="the capture to follow the new stream")
        start = capture.frames
        wait_for(lambda: capture.frames > start + 4800, what="the recording")
        x = capture.read(start, start + 4800)[:, 0].astype(np.float64)
        assert frequency(x) == pytest.approx(250.0, abs=0.5)  # the newest stimulus plays again
        assert device.connects == 2
    finally:
        device.stop()
        capture.stop()
