"""Timed stimuli on the audio clock (contracts C6), cue to port: a Vibration or PulseTrain with
`duration_ms` goes through the device manager's encoder to the audio worker and arrives at the
JACK port as exactly round(duration_ms · rate / 1000) samples, whenever its off comes."""

import time
from types import SimpleNamespace

import numpy as np
import pytest

from devices.audio.capture import Capture
from devices.audio.config import AudioChannel, AudioConfig
from devices.audio.mapping import AudioCueEncoder, TimedPattern, stimuli_for
from devices.audio.shell import AudioOutput
from devices.audio.synth import OFF, Stimulus
from devices.encoder import CueEncoder
from devices.manager import DeviceConfig, DeviceManager
from devices.profiles import AUDIO, FINGERTAC
from server.core.cues import PulseTrain, Stop, Vibration
from tests.audio.test_jack import RATE, config, frequency, wait_for

TIMED = Vibration(intensity_pct=50.0, carrier_hz=250.0, duration_ms=100.0)
PLANNED = 4800  # round(100 ms · 48 kHz)


@pytest.fixture
def rig(jack_server):
    capture = Capture(jack_server.name, 1).start()
    manager = DeviceManager([DeviceConfig(name="coil", profile=AUDIO, port=None, audio=config(jack_server))])
    manager.start()
    device = manager.devices["coil"].driver
    try:
        wait_for(lambda: device.status == "connected", what=f"the device to connect ({device.last_error})")
        wait_for(capture.connected, what="the capture to follow ViESTac's ports")
        wait_for(lambda: device.blocks > 100, what="the stream to run")
        yield manager, capture
    finally:
        manager.stop()
        capture.stop()


def play(manager, capture, schedule, tail_s: float = 0.3) -> np.ndarray:
    """Submit each (seconds from now, cues) of `schedule` at its time; the port's recording."""
    start = capture.frames
    t0 = time.monotonic()
    for at, cues in schedule:
        time.sleep(max(0.0, t0 + at - time.monotonic()))
        manager.submit(cues)
    until = start + (time.monotonic() - t0 + tail_s) * RATE
    wait_for(lambda: capture.frames > until, what="the recording")
    return capture.read(start)[:, 0].astype(np.float64)


def bursts(x: np.ndarray, gap: int = 2400) -> list[tuple[int, int]]:
    """(first, last) nonzero sample of each run of sound, runs apart by more than `gap` samples."""
    on = np.flatnonzero(x)
    if not len(on):
        return []
    breaks = np.flatnonzero(np.diff(on) > gap)
    firsts = np.concatenate(([on[0]], on[breaks + 1]))
    lasts = np.concatenate((on[breaks], [on[-1]]))
    return list(zip(firsts.tolist(), lasts.tolist()))


def length(burst: tuple[int, int]) -> int:
    return burst[1] - burst[0] + 1


def test_a_100_ms_stimulus_whose_off_comes_30_ms_late_is_still_4800_samples(rig):
    manager, capture = rig
    x = play(manager, capture, [(0.0, (TIMED,)), (0.130, ())])
    (burst,) = bursts(x)
    # the carrier starts at phase 0 (sin 0 = 0 is its first sample): plan − 1 … plan nonzero samples
    assert abs(length(burst) - PLANNED) <= 1, length(burst)
    first, last = burst
    assert frequency(x[first + 200:last - 200]) == pytest.approx(250.0, abs=0.5)
    assert np.max(np.abs(x)) == pytest.approx(0.5, rel=0.01)


def test_an_early_off_or_the_same_cue_sent_again_neither_shortens_nor_restarts_it(rig):
    manager, capture = rig
    x = play(manager, capture, [(0.0, (TIMED,)), (0.040, (TIMED,)), (0.070, ())])
    (burst,) = bursts(x)
    assert abs(length(burst) - PLANNED) <= 1, length(burst)


def test_a_2ifc_trial_two_intervals_500_ms_apart_each_exact(rig):
    manager, capture = rig
    x = play(manager, capture, [(0.0, (TIMED,)), (0.100, ()), (0.600, (TIMED,)), (0.700, ())])
    first, second = bursts(x)  # two, apart by more than 50 ms of silence
    assert abs(length(first) - PLANNED) <= 1 and abs(length(second) - PLANNED) <= 1, (first, second)
    # (the 500 ms between them are the tick clock's: not checked in samples, since a JACK dummy
    # server without real-time priority loses cycles on a busy machine, so its sample count between
    # two wall-clock moments falls short; a sound card's does not)
    # the same waveform in both intervals: the carrier starts at phase 0 each time
    a, b = x[first[0]:first[0] + PLANNED], x[second[0]:second[0] + PLANNED]
    assert np.max(np.abs(a - b)) < 1e-6


def test_a_timed_pulse_train_is_exact_too_and_a_stop_cuts_a_timed_stimulus(rig):
    manager, capture = rig
    cue = PulseTrain(t_on_ms=20.0, t_off_ms=30.0, intensity_pct=100.0, carrier_hz=250.0, duration_ms=110.0)
    x = play(manager, capture, [(0.0, (cue,)), (0.150, ())])
    runs = bursts(x, gap=240)  # bursts of 20 ms every 50 ms: 0-20, 50-70, 100-110 ms
    assert len(runs) == 3, runs
    assert runs[-1][1] - runs[0][0] + 1 <= round(0.110 * RATE)
    x = play(manager, capture, [(0.0, (Vibration(intensity_pct=50.0, duration_ms=2000.0),)), (0.3, (Stop(),))])
    (burst,) = bursts(x)
    assert length(burst) < RATE, "a Stop silences a timed stimulus now, not at its end"


def test_the_worker_hands_a_timed_stimulus_over_again_without_restarting_it():
    """Another channel's change republishes every channel (a new generation): the timed one goes
    on (equal, same onset); the next onset of the same waveform plays again in full."""
    cfg = AudioConfig(output="x", host_api="JACK", channels=(AudioChannel("a", 1), AudioChannel("b", 2)))
    output = AudioOutput(cfg)
    status = SimpleNamespace(output_underflow=False)
    block = np.zeros((64, 2), np.float32)
    out = []

    def render(blocks):
        for _ in range(blocks):
            output._callback(block, 64, None, status)
            out.append(block[:, 0].copy())

    timed = Stimulus("sine", 0.5, 250.0, duration=640, onset=1)
    output.publish(1, (timed, OFF))
    render(5)
    output.publish(2, (Stimulus.from_wire(timed.to_wire()), Stimulus("sine", 0.3, 100.0)))  # as from the wire
    render(15)
    output.publish(3, (Stimulus.from_wire({**timed.to_wire(), "onset": 2}), Stimulus("sine", 0.3, 100.0)))
    render(20)
    (first, second) = bursts(np.concatenate(out), gap=64)
    assert abs(length(first) - 640) <= 1 and abs(length(second) - 640) <= 1, (first, second)


def test_serial_devices_get_the_same_frames_and_the_audio_encoder_the_duration():
    for timed in (TIMED, PulseTrain(t_on_ms=20.0, t_off_ms=30.0, duration_ms=110.0)):
        untimed = type(timed)(**{**timed.__dict__, "duration_ms": None})
        serial = CueEncoder(FINGERTAC, "tac")
        assert [m.pack() for m in serial.encode((timed,)).commands.values()] == \
            [m.pack() for m in serial.encode((untimed,)).commands.values()]
    cfg = AudioConfig(output="x", host_api="JACK", channels=(AudioChannel("coil", 1),))
    commands = tuple(AudioCueEncoder(AUDIO, "coil", cfg).encode((TIMED,)).commands.values())
    assert [c.duration_ms for c in commands if isinstance(c, TimedPattern)] == [100.0]
    assert stimuli_for(commands, cfg, 250.0)[0].duration == PLANNED
