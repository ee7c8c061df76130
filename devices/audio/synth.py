"""The audio synthesis core: each channel's newest stimulus → samples, block by block. Sans-I/O.

Pure numpy, no clock, no threads: `Synth.render(out)` fills one block of a preallocated
(frames, channels) float32 buffer and advances its own sample clock (`Synth.sample`, the index
of the next block's first sample). The shell (devices/audio/shell.py) calls it from the audio
callback, so `render` allocates nothing: every intermediate array is a scratch buffer made in
`__init__` and every numpy call writes into one (`out=`).

A `Stimulus` is one channel's waveform:
- `sine`: a carrier at `frequency_hz`; `pulse`: the carrier gated `on_s` on, `off_s` off, repeating;
  `texture`: a zero-mean rectangular wave of frequency `frequency_hz` (the texture's 1/period) and
  duty `duty`, its edges rounded over `edge_s` (the switching is the vibration, as on FerroVibe);
  `off`: silence.
- `to_amplitude` / `to_frequency_hz`: a linear amplitude / frequency sweep over `sweep_s`, then held.
- `start` (an absolute sample of this synth's clock) and `duration` (samples): a stimulus of an
  exact length, for the intervals of a 2IFC trial: nothing before `start`, nothing from
  `start + duration` on, the attack and release ramps inside. Without `start` it begins with the
  next block; without `duration` it lasts until the next stimulus.
- `onset`: which onset of its channel a timed stimulus is (the device host numbers them): the same
  stimulus handed over again (another channel changed) is equal and goes on; a new onset of the
  same waveform (the next 2IFC interval) differs, and starts again.

Clicks: the output's envelope never steps. A new stimulus of the same kind (sine or pulse after
sine or pulse) keeps the carrier's phase and glides from the current level to its own over the
attack ramp; another kind (texture after sine, or any stimulus with a `start` or a `duration`)
first releases the sounding one to zero over the release ramp and then starts from silence, with
the carrier at phase 0 (so every 2IFC interval is the same waveform). Pulse trains ramp each
burst in and out (half of `on_s` at most). Ramps are linear: the envelope changes by at most
amplitude/ramp per second (amplitude/(ramp·rate) per sample), which the tests check.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

SHAPES = ("off", "sine", "pulse", "texture")
_CARRIER = ("sine", "pulse")  # the shapes that share the phase-continuous carrier


@dataclass(frozen=True)
class Stimulus:
    shape: str = "off"
    amplitude: float = 0.0              # peak, full scale = 1.0 (before the channel's gain and limit)
    frequency_hz: float = 0.0           # the carrier; a texture's 1/period
    on_s: float = 0.0                   # pulse: burst length
    off_s: float = 0.0                  # pulse: silence between bursts
    duty: float = 0.5                   # texture: the share of each period spent high
    to_amplitude: float | None = None   # sweep target, reached after sweep_s
    to_frequency_hz: float | None = None
    sweep_s: float = 0.0
    start: int | None = None            # absolute sample (Synth.sample clock); None: the next block
    duration: int | None = None         # samples; None: until the next stimulus
    onset: int = 0                      # a timed stimulus's onset number on its channel

    def __post_init__(self) -> None:
        if self.shape not in SHAPES:
            raise ValueError(f"stimulus shape must be one of {', '.join(SHAPES)}, got {self.shape!r}")
        for name in ("amplitude", "frequency_hz", "on_s", "off_s", "sweep_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"stimulus {name} must be a finite number >= 0, got {value!r}")
        for name in ("to_amplitude", "to_frequency_hz"):
            value = getattr(self, name)
            if value is not None and not (math.isfinite(value) and value >= 0):
                raise ValueError(f"stimulus {name} must be a finite number >= 0, got {value!r}")
        if not 0.0 <= self.duty <= 1.0:
            raise ValueError(f"stimulus duty must be in [0, 1], got {self.duty!r}")
        if self.shape == "pulse" and self.on_s <= 0:
            raise ValueError("a pulse stimulus needs on_s > 0")
        if self.duration is not None and self.duration < 1:
            raise ValueError(f"stimulus duration must be >= 1 sample, got {self.duration!r}")
        if self.onset < 0:
            raise ValueError(f"stimulus onset must be >= 0, got {self.onset!r}")

    def to_wire(self) -> dict:
        """The stimulus as a plain map (the audio worker's records, server/ipc/records.py)."""
        return {f: getattr(self, f) for f in _FIELDS}

    @classmethod
    def from_wire(cls, body: dict) -> Stimulus:
        return cls(**{f: body[f] for f in _FIELDS if f in body})

    @property
    def silent(self) -> bool:
        return self.shape == "off" or (self.amplitude == 0 and not self.to_amplitude)


_FIELDS = tuple(f.name for f in fields(Stimulus))
OFF = Stimulus()


class _Voice:
    """One channel's running state (plain attributes: read and written on the audio thread only)."""

    __slots__ = ("stimulus", "pending", "phase", "level", "glide_from", "glide_left", "begun", "releasing",
                 "release_from", "release_left", "age")

    def __init__(self) -> None:
        self.stimulus = OFF
        self.pending: Stimulus | None = None  # waits for the release of the sounding stimulus
        self.phase = 0.0        # carrier phase in cycles, [0, 1)
        self.level = 0.0        # the envelope's last value (the output's amplitude)
        self.glide_from = 0.0   # a same-kind change: the envelope moves from here ...
        self.glide_left = 0     # ... to the new stimulus's over this many more samples
        self.begun = True       # False while a stimulus waits for its start sample
        self.releasing = False  # the sounding stimulus fades out before `pending` begins
        self.release_from = 0.0
        self.release_left = 0
        self.age = 0            # samples since the stimulus began (pulse gate, sweeps, duration)


class Synth:
    """Render channels' stimuli into blocks. `rate` Hz, `channels` outputs, blocks of at most
    `max_frames`; `ramp_s` the attack and release time (a channel may have its own, `ramps_s`)."""

    def __init__(self, rate: int, channels: int, max_frames: int, *, ramp_s: float = 0.002,
                 ramps_s: tuple[float, ...] | None = None, edge_s: float = 0.0005):
        if rate <= 0 or channels <= 0 or max_frames <= 0:
            raise ValueError("rate, channels and max_frames must be > 0")
        self.rate = int(rate)
        self.channels = int(channels)
        self.max_frames = int(max_frames)
        ramps = ramps_s if ramps_s is not None else (ramp_s,) * channels
        if len(ramps) != channels or any(not (0 < r <= 1.0) for r in ramps):
            raise ValueError("each channel's ramp must be in (0, 1] s")
        self.ramp_samples = tuple(max(1, round(r * rate)) for r in ramps)
        self.edge_s = edge_s
        self.sample = 0  # the index of the next block's first sample on this synth's clock
        self.voices = [_Voice() for _ in range(channels)]
        self._inbox: list[Stimulus | None] = [None] * channels  # set by `set`, taken by `render`
        n = self.max_frames
        self._n = np.arange(n, dtype=np.float64)  # 0, 1, … the block's sample offsets
        self._freq = np.empty(n)
        self._phase = np.empty(n)
        self._env = np.empty(n)
        self._tmp = np.empty(n)
        self._tmp2 = np.empty(n)
        self._wave = np.empty(n)

    # ---- input: called between blocks (the shell does it on the audio thread) ----------------
    def set(self, channel: int, stimulus: Stimulus) -> None:
        """The newest stimulus of `channel`: taken at the next block (latest wins)."""
        self._inbox[channel] = stimulus

    # ---- output ------------------------------------------------------------------------------
    def render(self, out: np.ndarray) -> None:
        """Fill `out` ((frames, channels) float32, frames <= max_frames) with the next block."""
        frames = out.shape[0]
        if frames > self.max_frames:
            raise ValueError(f"block of {frames} frames exceeds max_frames {self.max_frames}")
        for ch in range(self.channels):
            new = self._inbox[ch]
            if new is not None:
                self._inbox[ch] = None
                self._take(self.voices[ch], new, self.ramp_samples[ch])
            self._render_voice(ch, frames)
            out[:, ch] = self._wave[:frames]
        self.sample += frames

    def _take(self, v: _Voice, new: Stimulus, ramp: int) -> None:
        old = v.stimulus
        sounding = v.level > 0.0 or (v.begun and not old.silent) or v.releasing
        restart = new.start is not None or new.duration is not None or \
            not (old.shape in _CARRIER and new.shape in _CARRIER) or not v.begun
        if sounding and restart and not new.silent:
            # a different waveform: fade the sounding one out first, then start from silence
            if not v.releasing:
                v.releasing, v.release_from, v.release_left = True, v.level, ramp
            v.pending = new
            return
        if sounding and new.silent:
            v.releasing, v.release_from, v.release_left, v.pending = True, v.level, ramp, OFF
            return
        if sounding:  # same carrier family: keep the phase, glide the level
            v.glide_from, v.glide_left = v.level, ramp
            self._begin(v, new, keep_phase=True)
            return
        v.pending, v.releasing = None, False
        self._begin(v, new, keep_phase=False)

    def _begin(self, v: _Voice, new: Stimulus, *, keep_phase: bool) -> None:
        v.stimulus, v.age = new, 0
        v.begun = new.start is None or new.start <= self.sample
        if not keep_phase:
            v.phase, v.glide_left = 0.0, 0

    def _render_voice(self, ch: int, frames: int) -> None:
        v = self.voices[ch]
        wave = self._wave[:frames]
        wave.fill(0.0)
        first = 0
        if v.releasing:
            first = self._release(ch, v, frames)
            if v.releasing:  # the release takes the whole block
                return
            new, v.pending = v.pending, None
            self._begin(v, new if new is not None else OFF, keep_phase=False)
        s = v.stimulus
        if s.silent:
            v.level = 0.0
            return
        if not v.begun:  # waiting for its start sample
            offset = s.start - (self.sample + first)
            if offset >= frames - first:
                return
            first += max(0, offset)
            v.begun = True
        self._sound(v, ch, first, frames)

    def _release(self, ch: int, v: _Voice, frames: int) -> int:
        """Continue the fade-out of the sounding stimulus; returns the first sample after it."""
        count = min(frames, v.release_left)
        if count > 0:
            step = v.release_from / self.ramp_samples[ch]
            env = self._env[:count]
            # env[k] = (release_left − 1 − k) · step: linear down to 0 at the ramp's last sample
            np.subtract(float(v.release_left - 1), self._n[:count], out=env)
            np.multiply(env, step, out=env)
            np.maximum(env, 0.0, out=env)
            self._carrier_or_texture(v, v.stimulus, 0, count, env)
            v.level = float(env[count - 1])
        v.release_left -= count
        if v.release_left <= 0:
            v.releasing, v.level = False, 0.0
        return count

    def _sound(self, v: _Voice, ch: int, first: int, frames: int) -> None:
        s = v.stimulus
        count = frames - first
        if s.duration is not None:
            count = min(count, max(0, s.duration - v.age))
        if count <= 0:
            v.level = 0.0
            if s.duration is not None and v.age >= s.duration:
                v.stimulus = OFF
            return
        ramp = self.ramp_samples[ch]
        env = self._env[:count]
        age = self._tmp[:count]
        np.add(self._n[:count], float(v.age), out=age)  # samples since the stimulus began
        self._amplitude(s, age, env)
        if s.shape == "pulse":
            self._pulse_gate(s, age, ramp, env)
        if s.duration is not None:  # attack from 0 and release to 0 inside the exact duration
            r = min(ramp, s.duration // 2) or 1
            gate = self._tmp2[:count]
            np.add(age, 0.5, out=gate)
            np.multiply(gate, 1.0 / r, out=gate)
            np.minimum(gate, 1.0, out=gate)
            np.multiply(env, gate, out=env)
            np.subtract(float(s.duration) - 0.5, age, out=gate)
            np.multiply(gate, 1.0 / r, out=gate)
            np.clip(gate, 0.0, 1.0, out=gate)
            np.multiply(env, gate, out=env)
        elif v.age == 0 and v.glide_left == 0 and first >= 0 and v.level == 0.0:
            v.glide_from, v.glide_left = 0.0, ramp  # from silence: an attack ramp
        if v.glide_left > 0:  # env moves from glide_from to the stimulus's own level
            g = min(count, v.glide_left)
            w = self._tmp2[:g]
            np.add(self._n[:g], float(ramp - v.glide_left + 1), out=w)
            np.multiply(w, 1.0 / ramp, out=w)  # weight of the new level, rising to 1
            head = env[:g]
            np.subtract(head, v.glide_from, out=head)
            np.multiply(head, w, out=head)
            head += v.glide_from
            v.glide_left -= g
        self._carrier_or_texture(v, s, first, count, env)
        v.level = float(env[count - 1])
        v.age += count
        if s.duration is not None and v.age >= s.duration:
            v.stimulus, v.level, v.glide_left = OFF, 0.0, 0

    def _amplitude(self, s: Stimulus, age: np.ndarray, env: np.ndarray) -> None:
        if s.to_amplitude is None or s.sweep_s <= 0:
            env.fill(s.amplitude)
            return
        span = s.sweep_s * self.rate
        np.multiply(age, 1.0 / span, out=env)
        np.minimum(env, 1.0, out=env)
        np.multiply(env, s.to_amplitude - s.amplitude, out=env)
        env += s.amplitude

    def _pulse_gate(self, s: Stimulus, age: np.ndarray, ramp: int, env: np.ndarray) -> None:
        """Bursts of on_s every on_s + off_s, each ramped in and out (no clicks at its edges)."""
        on = s.on_s * self.rate
        period = on + s.off_s * self.rate
        r = min(float(ramp), on / 2) or 1.0
        pos = self._tmp2[:age.shape[0]]
        np.fmod(age, period, out=pos)  # samples into the current burst
        gate = self._phase[:age.shape[0]]  # scratch: the carrier phase is computed after this
        np.add(pos, 0.5, out=gate)
        np.multiply(gate, 1.0 / r, out=gate)
        np.minimum(gate, 1.0, out=gate)
        np.subtract(on - 0.5, pos, out=pos)
        np.multiply(pos, 1.0 / r, out=pos)
        np.clip(pos, 0.0, 1.0, out=pos)
        np.multiply(gate, pos, out=gate)
        np.multiply(env, gate, out=env)

    def _carrier_or_texture(self, v: _Voice, s: Stimulus, first: int, count: int, env: np.ndarray) -> None:
        """wave[first:first+count] = env · the stimulus's waveform, advancing the carrier phase."""
        freq = self._freq[:count]
        if s.to_frequency_hz is None or s.sweep_s <= 0:
            freq.fill(s.frequency_hz)
        else:
            span = s.sweep_s * self.rate
            np.add(self._n[:count], float(v.age), out=freq)
            np.multiply(freq, 1.0 / span, out=freq)
            np.minimum(freq, 1.0, out=freq)
            np.multiply(freq, s.to_frequency_hz - s.frequency_hz, out=freq)
            freq += s.frequency_hz
        phase = self._phase[:count]
        np.multiply(freq, 1.0 / self.rate, out=freq)  # cycles per sample
        np.cumsum(freq, out=phase)
        np.subtract(phase, freq, out=phase)  # phase at each sample: before its own increment
        phase += v.phase
        next_phase = float(phase[count - 1] + freq[count - 1])
        v.phase = next_phase - math.floor(next_phase)
        wave = self._wave[first:first + count]
        if s.shape == "texture":
            self._texture(s, phase, wave)
        else:
            np.multiply(phase, 2.0 * math.pi, out=wave)
            np.sin(wave, out=wave)
        np.multiply(wave, env, out=wave)

    def _texture(self, s: Stimulus, phase: np.ndarray, wave: np.ndarray) -> None:
        """A zero-mean rectangle: high for `duty` of each cycle, edges ramped over edge_s (linear
        edges: the gate's mean is duty − edge, which is subtracted so a voice coil gets no DC)."""
        d = s.duty
        if d <= 0.0 or d >= 1.0:
            wave.fill(0.0)  # always low or always high: no switching, nothing to feel
            return
        per_cycle = s.frequency_hz / self.rate  # cycles per sample
        edge = max(self.edge_s * s.frequency_hz, per_cycle)  # edge length in cycles, at least a sample
        edge = min(edge, d / 2, (1 - d) / 2)
        np.fmod(phase, 1.0, out=wave)  # position in the cycle, [0, 1)
        pos = wave
        rise = self._tmp2[:wave.shape[0]]
        np.multiply(pos, 1.0 / edge, out=rise)
        np.minimum(rise, 1.0, out=rise)          # rising edge at 0
        np.subtract(d, pos, out=pos)
        np.multiply(pos, 1.0 / edge, out=pos)
        np.clip(pos, 0.0, 1.0, out=pos)          # falling edge ending at duty
        np.multiply(rise, pos, out=wave)         # 0..1 gate, mean d − edge over a cycle
        mean = d - edge
        np.subtract(wave, mean, out=wave)
        np.multiply(wave, 1.0 / max(mean, 1.0 - mean), out=wave)
