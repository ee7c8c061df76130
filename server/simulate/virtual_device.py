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

from dataclasses import dataclass

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
