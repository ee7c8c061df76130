"""Cues → audio stimuli, per actuator channel. Sans-I/O.

An audio tactor goes through the same cue encoder as every other device (devices/encoder.py):
its profile (`VOICECOIL` in devices/profiles.py, or a rig file's own) says which cues it shows,
and the encoder's pattern command becomes each channel's `Stimulus` here:

| pattern command (from cue)                         | stimulus on each actuator channel                          |
|----------------------------------------------------|-------------------------------------------------------------|
| off (no cue, Stop)                                 | silence (released over the ramp)                            |
| continuous (Vibration, Tilt shown as "(!)")        | sine at the carrier (0: the profile's carrier)              |
| pulse (PulseTrain, Stiffness as "(!)")             | the sine gated on_ms on, off_ms off, each burst ramped      |
| texture (Texture, fine roughness "!")              | zero-mean rectangle at 1/period with the texture's duty     |
| tilt, temperature, friction                        | refused by the encoder (the profile does not display them)  |

The drive level is intensity/100 · the channel's gain, never above its `peak`. A carrier outside a
channel's `frequency_hz` is refused (`AudioCueEncoder`, code `out_of_range`) rather than played at
a frequency nobody asked for.

Timed stimuli (contracts C6): a Vibration or PulseTrain with `duration_ms` is the pattern command
wrapped in a `TimedPattern`, which becomes a stimulus of exactly round(duration_ms · rate / 1000)
samples on the audio clock (the attack and release inside). SetPattern, the serial wire message,
has no field for it and is left as it is: only the audio encoder wraps, and the wrapper never
leaves the device host. A Stop cue is `CUT` (silence now, a timed stimulus included); no cue is
plain silence, which a timed stimulus outlasts (devices/audio/device.py: the off that follows it
never shortens it, however late or early it comes).
"""

from __future__ import annotations

from dataclasses import dataclass

from devices.audio.config import AudioConfig
from devices.audio.synth import OFF, Stimulus
from devices.encoder import CueEncoder, Encoding, Refusal
from devices.messages import PatternMode, SetPattern
from server.core.cues import PulseTrain, Stop, Vibration


@dataclass(frozen=True)
class TimedPattern:
    """A pattern command that lasts exactly `duration_ms` from its onset (the audio encoder's)."""
    pattern: SetPattern
    duration_ms: float


@dataclass(frozen=True)
class Cut:
    """A Stop cue's pattern on an audio tactor: silence now, a timed stimulus cut short."""


CUT = Cut()


def carrier_of(command: SetPattern, default_hz: float) -> float:
    return float(command.carrier_hz or default_hz)


def stimuli_for(commands, config: AudioConfig, default_hz: float) -> tuple[Stimulus, ...]:
    """The stimulus of each configured channel (in config.channels order) for one encoding's
    commands; layers other than the pattern have no audio meaning and are ignored."""
    pattern = next((c for c in commands if isinstance(c, (SetPattern, TimedPattern))), None)
    duration = None
    if isinstance(pattern, TimedPattern):
        duration = round(pattern.duration_ms * config.sample_rate / 1000)
        pattern = pattern.pattern if duration >= 1 else None  # 0 ms: nothing to play
    if pattern is None or pattern.mode == PatternMode.OFF or pattern.intensity == 0 or \
            (pattern.mode != PatternMode.CONTINUOUS and pattern.on_us == 0):  # on_us 0: never on
        return (OFF,) * len(config.channels)
    out = []
    for ch in config.channels:
        amplitude = ch.drive(pattern.intensity)
        if pattern.mode == PatternMode.TEXTURE:
            period_s = (pattern.on_us + pattern.off_us) / 1e6
            out.append(Stimulus("texture", amplitude, 1.0 / period_s, duty=pattern.on_us / (pattern.on_us + pattern.off_us)))
            continue
        hz = carrier_of(pattern, default_hz)
        if pattern.mode == PatternMode.CONTINUOUS or pattern.off_us == 0:
            out.append(Stimulus("sine", amplitude, hz, duration=duration))
        else:
            out.append(Stimulus("pulse", amplitude, hz, on_s=pattern.on_us / 1e6, off_s=pattern.off_us / 1e6,
                                duration=duration))
    return tuple(out)


def is_cut(commands) -> bool:
    """A Stop cue's encoding: silence now, a timed stimulus cut short."""
    return any(isinstance(c, Cut) for c in commands)


class AudioCueEncoder(CueEncoder):
    """The cue encoder, plus the channels' frequency limits: a carrier none of the actuators may
    play is refused with the range it would have needed."""

    def __init__(self, profile, device: str | None, config: AudioConfig):
        super().__init__(profile, device)
        self.config = config

    def encode(self, cues) -> Encoding:
        encoding = super().encode(cues)
        if any(isinstance(c, Stop) for c in cues) and "pattern" in encoding.commands:
            return Encoding({**encoding.commands, "pattern": CUT}, encoding.refusals)
        return encoding

    def _encode_one(self, cue):
        result = super()._encode_one(cue)
        if isinstance(result, Refusal):
            return result
        layer, command = result
        if isinstance(command, SetPattern) and command.mode in (PatternMode.PULSE, PatternMode.CONTINUOUS):
            hz = carrier_of(command, self.profile.carrier_hz)
            refused = [c for c in self.config.channels if not c.accepts(hz)]
            if refused:
                c = refused[0]
                return self._refuse(cue, "out_of_range", f"its carrier {hz:g} Hz is outside {c.actuator}'s "
                                    f"{c.frequency_hz[0]:g}-{c.frequency_hz[1]:g} Hz")
            if isinstance(cue, (Vibration, PulseTrain)) and cue.duration_ms is not None:
                return layer, TimedPattern(command, cue.duration_ms)
        return result
