"""A tactile device on the virtual clock: the production byte path without a port.

cues → CueEncoder (the device profile) → DeviceSession (latest-wins layers, link budget,
handshake) → SimulatedLink (115200 8N1 byte times) → the device's C firmware core (Firmware)
→ actuator edges, each stamped with its exact scheduled time. The same code as a real rig or the
pty emulators, only the clock is the study's virtual clock, so a simulated study runs faster
than real time and the participant model feels exactly what a device would play.

`Feel` turns the edges into what a fingertip perceives, and nothing else: whether the actuator
vibrates now, the interval between the last two pulse onsets (the pulse rate), how long it has
been on or off, and the magnet's tilt. A synthetic participant decides from this, never from the
scene's true positions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from devices.audio.config import AudioChannel, AudioConfig
from devices.audio.mapping import AudioCueEncoder, stimuli_for
from devices.audio.synth import OFF
from devices.encoder import CueEncoder
from devices.simulated_link import SimulatedLink
from devices.firmware_binding import Edge, Firmware
from devices.profiles import DeviceProfile
from devices.protocol import DeviceSession


class FirmwareDevice:
    """The device end of a SimulatedLink: the C firmware core with times in seconds."""

    def __init__(self, model: str):
        self.core = Firmware(model)

    def receive_data(self, data: bytes, now_s: float) -> None:
        self.core.receive(data, _us(now_s))

    def data_to_send(self) -> bytes:
        return self.core.take_output()


def _us(t_s: float) -> int:
    return round(t_s * 1e6)  # round() of a float or int is an int already


@dataclass
class ChannelFeel:
    on: bool = False                 # vibrating (or pulsing in its on phase) now
    intensity: int = 0               # % of the current on phase
    since_s: float = 0.0             # when the current on/off phase began
    onsets: tuple[float, float] | None = None  # the last two pulse onsets (s), for the interval
    count: int = 0                   # onsets so far (a reader waits for fresh ones after moving)
    direction_deg: float = 0.0       # tilt direction (0 front, 90 right, 180 back, 270 left)
    magnitude: int = 0               # tilt %, 0 = flat


class Feel:
    """What a fingertip perceives of one device, from its actuator edges. `catch_up` (the
    device's) runs before every read, so the device has played everything up to now."""

    def __init__(self, channels: int, catch_up=lambda: None):
        self._channels = [ChannelFeel() for _ in range(channels)]
        self._catch_up = catch_up

    @property
    def channels(self) -> list[ChannelFeel]:
        self._catch_up()
        return self._channels

    def apply(self, edges: list[Edge]) -> None:
        for e in edges:
            c = self._channels[e.channel]
            t = e.t_us / 1e6
            if e.gate and not c.on:
                c.onsets = (c.onsets[1] if c.onsets else t, t)
                c.count += 1
            if e.gate != c.on:
                c.since_s = t
            c.on, c.intensity = e.gate, e.intensity if e.gate else 0
            c.direction_deg, c.magnitude = e.direction_cdeg / 100.0, e.magnitude

    def pulse_interval_s(self, now_s: float, channel: int = 0) -> float | None:
        """Onset-to-onset time of the pulse train; None while continuous, silent or after a
        single onset. A pause longer than the last interval counts: the train slowed down."""
        c = self.channels[channel]
        if c.onsets is None or c.onsets[0] == c.onsets[1]:
            return None
        interval = c.onsets[1] - c.onsets[0]
        return max(interval, now_s - c.onsets[1]) if not c.on else interval

    def onsets(self, channel: int = 0) -> int:
        return self.channels[channel].count

    def continuous(self, now_s: float, channel: int = 0, longer_than_s: float = 0.3) -> bool:
        c = self.channels[channel]
        return c.on and now_s - c.since_s >= longer_than_s

    def tilt(self, channel: int = 0) -> tuple[float, int]:
        c = self.channels[channel]
        return c.direction_deg, c.magnitude


class VirtualDevice:
    """`fault`: a function applied to every tick's cues before encoding — a deliberately broken
    cue for tests that a participant model fails visibly when the cue lies.

    The device runs lazily: `run_until(t)` only records how far it is due, and the line and the
    firmware catch up when something needs them (a command handed over, the feel, the edges, the
    status read). That gives the same bytes, edges and feel as running every tick: the link and
    the firmware core are event-driven (every arrival, host wake and actuator edge is handled at
    its own time, and the core plays the edges due before a frame acts), and a command is handed
    over only after the catch-up to its tick, as before. What goes are four of five catch-ups, the
    calls per device per tick between events (2.5 % of a simulated participant's time)."""

    def __init__(self, name: str, profile: DeviceProfile, fault=None):
        self.name, self.profile, self.fault = name, profile, fault
        self.encoder = CueEncoder(profile)
        self.host = DeviceSession()
        self.device = FirmwareDevice(profile.model)
        self.link = SimulatedLink(self.host, self.device)
        self.link.plug()
        self._core = self.device.core
        self.feel = Feel(len(profile.channels), self.catch_up)
        self._edges: list[Edge] = []     # every actuator edge so far (the device's timeline)
        self.refusals: tuple[str, ...] = ()
        self._due_s = 0.0                # where run_until left the device due
        self._done_s = 0.0               # where the line and the firmware have run to

    @property
    def status(self) -> str:
        self.catch_up()
        return self.host.status

    @property
    def edges(self) -> list[Edge]:
        """Every actuator edge so far (the device's timeline)."""
        self.catch_up()
        return self._edges

    def submit(self, cues) -> None:
        """The tick's cues, as the device manager would hand them over (latest wins)."""
        self.catch_up()  # the host sets the command at the time it is handed over
        cues = tuple(cues) if self.fault is None else tuple(self.fault(tuple(cues)))
        encoding = self.encoder.encode(cues)
        self.refusals = encoding.refusals
        for command in encoding.commands.values():
            self.link.set(command)

    def run_until(self, t_s: float) -> None:
        """The device is due at t_s (the end of a tick); it runs there when it is next needed."""
        self._due_s = t_s

    def catch_up(self) -> None:
        """Move the line and the firmware to where they are due (the edges go to feel and edges)."""
        t_s = self._due_s
        if t_s == self._done_s:
            return
        self._done_s = t_s
        self.link.run_until(t_s)
        edges = self._core.advance(_us(t_s))
        if edges:
            self.feel.apply(edges)
            self._edges.extend(edges)


class VirtualAudioDevice:
    """An audio tactor (a voice coil on a sound interface) on the virtual clock: the audio path's
    own encoder (AudioCueEncoder: the profile and the channels' frequency limits) and cue →
    stimulus mapping (devices/audio/mapping.py), with the synth's gating (a sine is on, a pulse
    stimulus on for on_s and off for off_s from its start, a texture on) turned into actuator
    edges. An audio device has no byte line and no firmware: a stimulus starts when it is handed
    over (the sound interface's block of latency is below a tick of the study's clock)."""

    def __init__(self, name: str, profile: DeviceProfile, config: AudioConfig | None = None):
        self.name, self.profile = name, profile
        self.config = config or AudioConfig(output="virtual", host_api="virtual", channels=tuple(
            AudioChannel(actuator, i + 1) for i, actuator in enumerate(profile.channels)))
        self.encoder = AudioCueEncoder(profile, name, self.config)
        self.feel = Feel(len(self.config.channels), self.catch_up)
        self._edges: list[Edge] = []
        self.refusals: tuple = ()
        self._playing = [(OFF, 0.0)] * len(self.config.channels)  # (stimulus, start s) per channel
        self._due_s = self._done_s = 0.0

    status = "connected"  # no line to lose: the device host's supervisor owns a real stream's status

    @property
    def edges(self) -> list[Edge]:
        self.catch_up()
        return self._edges

    def submit(self, cues) -> None:
        self.catch_up()
        encoding = self.encoder.encode(tuple(cues))
        self.refusals = encoding.refusals
        stimuli = stimuli_for(encoding.commands.values(), self.config, self.profile.carrier_hz)
        for ch, stimulus in enumerate(stimuli):
            if stimulus != self._playing[ch][0]:
                self._playing[ch] = (stimulus, self._done_s)
                self._emit(ch, self._done_s, "command")

    def run_until(self, t_s: float) -> None:
        self._due_s = t_s

    def catch_up(self) -> None:
        """A pulse stimulus's bursts up to where the device is due, as edges."""
        t_end, start_s = self._due_s, self._done_s
        if t_end == start_s:
            return
        self._done_s = t_end
        for ch, (s, t0) in enumerate(self._playing):
            if s.shape != "pulse" or s.silent:
                continue
            period = s.on_s + s.off_s
            k = math.floor((start_s - t0) / period)
            while True:  # the burst boundaries in (start_s, t_end]
                for t, gate in ((t0 + k * period, True), (t0 + k * period + s.on_s, False)):
                    if start_s < t <= t_end:
                        self._emit(ch, t, "schedule", gate)
                if t0 + (k + 1) * period > t_end:
                    break
                k += 1

    def _emit(self, ch: int, t_s: float, cause: str, gate: bool | None = None) -> None:
        s = self._playing[ch][0]
        on = (not s.silent) if gate is None else gate
        mode = {"off": 0, "pulse": 1, "sine": 2, "texture": 3}.get(s.shape, 2)
        edge = Edge(_us(t_s), ch, on, mode if not s.silent else 0, round(min(s.amplitude, 1.0) * 100) if on else 0,
                    round(s.frequency_hz) if s.shape in ("sine", "pulse") else 0, 0, 0, cause)
        self._edges.append(edge)
        self.feel.apply([edge])


def virtual_device(name: str, profile: DeviceProfile):
    """The virtual device of a profile: an audio tactor's audio path, or the serial byte path."""
    return VirtualAudioDevice(name, profile) if profile.protocol == "audio" else VirtualDevice(name, profile)
