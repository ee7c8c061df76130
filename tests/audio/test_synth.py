"""The synthesis core (devices/audio/synth.py), sans-I/O: frequency, amplitude, exact duration,
envelope slopes, phase continuity across blocks and parameter changes."""

import math
import tracemalloc

import numpy as np
import pytest

from devices.audio.synth import Stimulus, Synth

RATE = 48_000


def run(synth: Synth, blocks: int, frames: int = 64, changes: dict | None = None) -> np.ndarray:
    """Render `blocks` blocks; `changes` maps a block number to [(channel, stimulus)] set before it."""
    out = np.zeros((frames, synth.channels), np.float32)
    rendered = []
    for b in range(blocks):
        for ch, stim in (changes or {}).get(b, ()):
            synth.set(ch, stim)
        synth.render(out)
        rendered.append(out.copy())
    return np.concatenate(rendered)


def frequency(x: np.ndarray) -> float:
    """The peak of the Hann-windowed, 16× zero-padded spectrum, refined by a parabola through the
    log magnitudes of its three bins (a few mHz for a pure tone of ≥ 50 ms at 48 kHz)."""
    n = 16 * len(x)
    spectrum = np.log(np.abs(np.fft.rfft(x * np.hanning(len(x)), n)) + 1e-30)
    k = int(np.argmax(spectrum))
    a, b, c = spectrum[k - 1:k + 2]
    return float((k + 0.5 * (a - c) / (a - 2 * b + c)) * RATE / n)


@pytest.mark.parametrize("hz", [40.0, 235.0, 250.0, 997.0])
def test_a_sine_has_its_frequency_and_amplitude(hz):
    x = run(Synth(RATE, 1, 64), 200, changes={0: [(0, Stimulus("sine", 0.4, hz))]})[:, 0]
    steady = x[2000:]
    assert frequency(steady) == pytest.approx(hz, abs=0.05)
    assert np.max(np.abs(steady)) == pytest.approx(0.4, rel=1e-3)


@pytest.mark.parametrize("frames", [32, 64, 100, 256])
def test_an_exact_stimulus_lasts_exactly_its_samples_whatever_the_block(frames):
    start, duration = 1000, 4800  # 100 ms at 48 kHz, starting inside a block
    synth = Synth(RATE, 1, frames)
    x = run(synth, 12_000 // frames, frames,
            changes={0: [(0, Stimulus("sine", 0.5, 250.0, start=start, duration=duration))]})[:, 0]
    assert not np.any(x[:start]) and not np.any(x[start + duration:])
    # the carrier starts at phase 0 (sin 0 = 0): the envelope is nonzero from `start` on
    nonzero = np.nonzero(x)[0]
    assert nonzero[0] == start + 1 and nonzero[-1] == start + duration - 1
    assert np.max(np.abs(x)) == pytest.approx(0.5, rel=1e-3)


def test_the_envelope_never_steps_more_than_its_ramp_allows():
    ramp_s = 0.002
    amplitude = 0.8
    synth = Synth(RATE, 1, 64, ramp_s=ramp_s)
    changes = {0: [(0, Stimulus("sine", amplitude, 250.0))], 30: [(0, Stimulus("sine", 0.1, 400.0))],
               60: [(0, Stimulus("texture", amplitude, 100.0, duty=0.3))], 90: [(0, Stimulus())],
               120: [(0, Stimulus("pulse", amplitude, 250.0, on_s=0.01, off_s=0.01))],
               200: [(0, Stimulus("sine", amplitude, 250.0, start=200 * 64 + 10, duration=2400))]}
    x = run(synth, 300, changes=changes)[:, 0].astype(np.float64)
    # a 250 Hz sine at 0.8 moves at most 2π·f·A/rate per sample; the envelope adds A/(ramp·rate)
    carrier_step = 2 * math.pi * 400 * amplitude / RATE
    envelope_step = amplitude / (ramp_s * RATE)
    steps = np.abs(np.diff(x))
    sine_part = steps[:60 * 64]
    assert sine_part.max() <= carrier_step + envelope_step + 1e-6
    # from silence: the first sample is within one envelope step of 0
    assert abs(x[0]) <= envelope_step + 1e-9


def test_the_onset_and_offset_ramps_are_linear_and_bounded():
    synth = Synth(RATE, 1, 64, ramp_s=0.005)
    x = run(synth, 100, changes={0: [(0, Stimulus("sine", 1.0, 250.0, start=0, duration=4800))]})[:, 0]
    peaks = np.abs(x[:240])  # 5 ms ramp = 240 samples: |x| stays under the ramp line
    assert np.all(peaks <= (np.arange(240) + 0.5) / 240 + 1e-6)
    tail = np.abs(x[4800 - 240:4800])
    assert np.all(tail <= (240 - np.arange(240) - 0.5) / 240 + 1e-6)


def test_the_phase_runs_on_across_blocks_and_frequency_changes():
    synth = Synth(RATE, 1, 64)
    x = run(synth, 100, changes={0: [(0, Stimulus("sine", 0.5, 250.0))], 50: [(0, Stimulus("sine", 0.5, 300.0))]})
    x = x[:, 0].astype(np.float64)
    # instantaneous phase from the sample values: a continuous phase has no jump between samples
    # larger than the highest frequency's increment (plus rounding)
    before, after = x[50 * 64 - 64:50 * 64], x[50 * 64:50 * 64 + 64]
    join = np.concatenate([before, after])
    assert np.max(np.abs(np.diff(join))) <= 2 * math.pi * 300 * 0.5 / RATE + 1e-6
    # the exact continuation: phase(n) = Σ f/rate
    expected_phase = (50 * 64 * 250 + np.arange(64) * 300) / RATE
    assert after == pytest.approx(0.5 * np.sin(2 * math.pi * expected_phase), abs=1e-6)


def test_a_pulse_train_is_on_and_off_for_its_times():
    synth = Synth(RATE, 1, 64, ramp_s=0.001)
    x = run(synth, 100, changes={0: [(0, Stimulus("pulse", 0.5, 250.0, on_s=0.02, off_s=0.03))]})[:, 0]
    on = np.abs(x) > 0
    # bursts start every 50 ms and nothing sounds in the 30 ms between them
    for k in range(2):
        assert not np.any(on[k * 2400 + 960:(k + 1) * 2400])
        assert np.any(on[k * 2400:k * 2400 + 960])


def test_a_frequency_sweep_and_an_amplitude_sweep_reach_their_targets():
    synth = Synth(RATE, 1, 64)
    stim = Stimulus("sine", 0.1, 100.0, to_amplitude=0.5, to_frequency_hz=300.0, sweep_s=0.1)
    x = run(synth, 300, changes={0: [(0, stim)]})[:, 0]
    assert frequency(x[4800 + 200:]) == pytest.approx(300.0, abs=0.05)
    assert np.max(np.abs(x[4800 + 200:])) == pytest.approx(0.5, rel=1e-3)
    assert 0.1 < np.max(np.abs(x[300:600])) <= 0.1 + 0.4 * 600 / 4800 + 1e-6  # linear from 0.1


def test_a_texture_has_no_dc_and_its_period():
    synth = Synth(RATE, 1, 64)
    x = run(synth, 300, changes={0: [(0, Stimulus("texture", 0.5, 125.0, duty=0.3))]})[:, 0].astype(np.float64)
    steady = x[960:960 + 48000 // 125 * 40]  # 40 whole periods
    assert abs(steady.mean()) < 1e-3
    assert np.max(np.abs(steady)) <= 0.5 + 1e-6
    assert frequency(steady) == pytest.approx(125.0, abs=0.1)


def test_render_allocates_no_arrays():
    """The audio callback must not allocate: with blocks of 1024 frames any temporary array would
    take ≥ 8 KiB; what render leaves behind or peaks at is Python's small objects only."""
    frames = 1024
    synth = Synth(RATE, 2, frames)
    out = np.zeros((frames, 2), np.float32)
    synth.set(0, Stimulus("pulse", 0.5, 250.0, on_s=0.01, off_s=0.01, to_frequency_hz=300.0, sweep_s=1.0))
    synth.set(1, Stimulus("texture", 0.5, 100.0, duty=0.3))
    for _ in range(5):
        synth.render(out)
    # tracemalloc sees every thread: another test's leftover thread may allocate in the window now
    # and then, a temporary array in render would show in every window; so the least of three,
    # each window the same work (a timed sine starting in it, the texture going on)
    grown = []
    for _ in range(3):
        synth.set(0, Stimulus("sine", 0.2, 250.0, start=synth.sample + 100, duration=5000))
        tracemalloc.start()
        try:
            before = tracemalloc.get_traced_memory()[0]
            for _ in range(200):
                synth.render(out)
            current, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
        grown.append((peak - before, current - before))
    assert min(p for p, _ in grown) < 8 * frames, grown
    assert min(c for _, c in grown) < 1024, grown


def test_bad_stimuli_and_oversized_blocks_are_refused():
    synth = Synth(RATE, 2, 64)
    with pytest.raises(ValueError, match="exceeds max_frames"):
        synth.render(np.zeros((65, 2), np.float32))
    with pytest.raises(ValueError, match="pulse stimulus needs on_s"):
        Stimulus("pulse", 0.5, 250.0)
    with pytest.raises(ValueError, match="shape must be one of"):
        Stimulus("square", 0.5, 250.0)
