"""An audio device's configuration: the `[device.audio]` table of a rig file. Sans-I/O.

A voice-coil tactor (or an LRA, a Haptuator) behind an amplifier is a channel of a sound
interface. The table names the output device by its name and host API, never by PortAudio's
index (indices change with what else is plugged in), the sample rate and block size, and each
actuator's channel (1-based, as interfaces label their outputs), gain, limits and optional
calibration (docs/devices.md "Audio tactors"):

    [device.audio]
    output = "system"            # the output device's name as PortAudio lists it (exact, else a unique part)
    host_api = "JACK"            # a part of the host API's name: JACK, ALSA, PulseAudio, Core Audio, WASAPI, ASIO
    jack_server = "viestac-sim"  # optional: the JACK server's name (else JACK's default)
    sample_rate = 48000
    block = 64                   # frames per block: 32..1024
    ramp_ms = 2.0                # attack and release of every change (no clicks)

    [[device.audio.channel]]
    actuator = "coil"
    channel = 1
    gain = 1.0                   # drive = intensity/100 · gain ...
    peak = 0.9                   # ... never above this (full scale 1.0)
    frequency_hz = [20, 1000]    # carriers outside are refused (a cue's reason says so)
    calibration = { unit = "m/s^2", points = [[20, 1.0, 4.0], [250, 0.5, 9.5], [250, 1.0, 19.0], [1000, 1.0, 6.0]] }

Calibration points are `[frequency_hz, drive, peak]`: the measured peak displacement (`m`) or
acceleration (`m/s^2`) at that frequency and drive level. Between points the peak is linear in
drive (through 0 at drive 0) and in frequency; `Calibration.drive_for` inverts it, so a level can
be asked for and reported in physical units.

What needs the machine (is the output device there, has it the channels, does it run at the rate)
is checked by the shell when the device starts (`check_output`, with PortAudio's lists passed in):
a bad configuration is refused with a message that names it, and the rest of the rig runs.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

UNITS = ("m", "m/s^2")
BLOCK_RANGE = (32, 1024)
RATE_RANGE = (8_000, 192_000)


class AudioConfigError(ValueError):
    pass


@dataclass(frozen=True)
class Calibration:
    unit: str
    points: tuple[tuple[float, float, float], ...]  # (frequency_hz, drive, peak), sorted

    def __post_init__(self) -> None:
        if self.unit not in UNITS:
            raise AudioConfigError(f"calibration unit must be one of {', '.join(UNITS)}, got {self.unit!r}")
        if not self.points:
            raise AudioConfigError("calibration needs at least one point [frequency_hz, drive, peak]")
        points = []
        for p in self.points:
            if len(p) != 3 or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in p):
                raise AudioConfigError(f"calibration point {p!r}: expected [frequency_hz, drive, peak], finite numbers")
            f, drive, peak = (float(v) for v in p)
            if f <= 0 or not 0 < drive <= 1 or peak <= 0:
                raise AudioConfigError(f"calibration point {list(p)}: frequency > 0, drive in (0, 1], peak > 0")
            points.append((f, drive, peak))
        points.sort()
        for f in self.frequencies:
            curve = [pk for ff, _, pk in points if ff == f]
            if any(b <= a for a, b in zip(curve, curve[1:])):
                raise AudioConfigError(f"calibration at {f:g} Hz: the peak must rise with the drive level")
        object.__setattr__(self, "points", tuple(points))

    @property
    def frequencies(self) -> tuple[float, ...]:
        return tuple(sorted({float(p[0]) for p in self.points}))

    def covers(self, low_hz: float, high_hz: float) -> bool:
        freqs = self.frequencies
        return freqs[0] <= low_hz and high_hz <= freqs[-1]

    def _curve_peak(self, f: float, drive: float) -> float:
        """Peak at calibrated frequency f: piecewise linear in drive through (0, 0), extended
        beyond the highest calibrated drive by its last segment."""
        curve = [(0.0, 0.0)] + [(d, pk) for ff, d, pk in self.points if ff == f]
        for (d0, p0), (d1, p1) in zip(curve, curve[1:]):
            if drive <= d1:
                return p0 + (p1 - p0) * (drive - d0) / (d1 - d0)
        (d0, p0), (d1, p1) = curve[-2], curve[-1]
        return p0 + (p1 - p0) * (drive - d0) / (d1 - d0)

    def peak_for(self, frequency_hz: float, drive: float) -> float:
        """The physical peak (in `unit`) a drive level gives at a frequency."""
        freqs = self.frequencies
        if not freqs[0] <= frequency_hz <= freqs[-1]:
            raise AudioConfigError(f"{frequency_hz:g} Hz is outside the calibration ({freqs[0]:g}-{freqs[-1]:g} Hz)")
        i = bisect.bisect_left(freqs, frequency_hz)
        if freqs[i] == frequency_hz:
            return self._curve_peak(freqs[i], drive)
        f0, f1 = freqs[i - 1], freqs[i]
        w = (frequency_hz - f0) / (f1 - f0)
        return (1 - w) * self._curve_peak(f0, drive) + w * self._curve_peak(f1, drive)

    def drive_for(self, frequency_hz: float, peak: float) -> float:
        """The drive level that gives `peak` at `frequency_hz` (the inverse of peak_for)."""
        low, high = 0.0, 1.0
        while self.peak_for(frequency_hz, high) < peak and high < 1e6:
            high *= 2
        for _ in range(60):  # bisection: peak_for rises with the drive
            mid = (low + high) / 2
            low, high = (mid, high) if self.peak_for(frequency_hz, mid) < peak else (low, mid)
        return (low + high) / 2

    @classmethod
    def from_dict(cls, data: Mapping, where: str) -> Calibration:
        if not isinstance(data, Mapping) or set(data) - {"unit", "points"} or "points" not in data:
            raise AudioConfigError(f"{where}: calibration must be a table {{ unit = \"m/s^2\", points = [[f, drive, "
                                   f"peak], ...] }}")
        try:
            return cls(unit=str(data.get("unit", "m/s^2")), points=tuple(tuple(p) for p in data["points"]))
        except AudioConfigError as exc:
            raise AudioConfigError(f"{where}: {exc}") from None
        except TypeError:
            raise AudioConfigError(f"{where}: calibration points must be lists [frequency_hz, drive, peak]") from None


@dataclass(frozen=True)
class AudioChannel:
    actuator: str
    channel: int                      # 1-based output number
    gain: float = 1.0
    peak: float = 1.0                 # the largest drive level sent (full scale 1.0)
    frequency_hz: tuple[float, float] = (20.0, 1000.0)
    calibration: Calibration | None = None

    def __post_init__(self) -> None:
        if not self.actuator:
            raise AudioConfigError("an audio channel needs an actuator name")
        if not isinstance(self.channel, int) or self.channel < 1:
            raise AudioConfigError(f"{self.actuator}: channel must be an output number >= 1, got {self.channel!r}")
        if not (math.isfinite(self.gain) and self.gain > 0):
            raise AudioConfigError(f"{self.actuator}: gain must be > 0, got {self.gain!r}")
        if not 0 < self.peak <= 1:
            raise AudioConfigError(f"{self.actuator}: peak must be in (0, 1] (full scale), got {self.peak!r}")
        low, high = self.frequency_hz
        if not 0 < low < high:
            raise AudioConfigError(f"{self.actuator}: frequency_hz must be [low, high] with 0 < low < high")

    def drive(self, intensity_pct: float) -> float:
        return min(self.peak, intensity_pct / 100.0 * self.gain)

    def accepts(self, frequency_hz: float) -> bool:
        low, high = self.frequency_hz
        return low <= frequency_hz <= high


@dataclass(frozen=True)
class AudioConfig:
    output: str
    host_api: str
    channels: tuple[AudioChannel, ...]
    sample_rate: int = 48_000
    block: int = 64
    ramp_ms: float = 2.0
    jack_server: str | None = None

    def __post_init__(self) -> None:
        if not self.output or not self.host_api:
            raise AudioConfigError("audio: output (the device's name) and host_api (e.g. JACK, ALSA) are required")
        if not self.channels:
            raise AudioConfigError("audio: at least one [[device.audio.channel]]")
        actuators = [c.actuator for c in self.channels]
        numbers = [c.channel for c in self.channels]
        if len(set(actuators)) != len(actuators) or len(set(numbers)) != len(numbers):
            raise AudioConfigError("audio: each actuator and each channel number once")
        if not BLOCK_RANGE[0] <= self.block <= BLOCK_RANGE[1]:
            raise AudioConfigError(f"audio: block must be {BLOCK_RANGE[0]}..{BLOCK_RANGE[1]} frames, got {self.block}")
        if not RATE_RANGE[0] <= self.sample_rate <= RATE_RANGE[1]:
            raise AudioConfigError(f"audio: sample_rate must be {RATE_RANGE[0]}..{RATE_RANGE[1]} Hz, "
                                   f"got {self.sample_rate}")
        if not 0.1 <= self.ramp_ms <= 100:
            raise AudioConfigError(f"audio: ramp_ms must be 0.1..100, got {self.ramp_ms}")

    @property
    def actuators(self) -> tuple[str, ...]:
        return tuple(c.actuator for c in self.channels)

    @property
    def outputs(self) -> int:
        """How many output channels the stream opens (up to the highest one used)."""
        return max(c.channel for c in self.channels)

    def describe(self) -> str:
        return f"audio:{self.output}@{self.host_api}"

    def check(self) -> list[str]:
        """What the file says that cannot work, in words (no machine needed): a calibration that
        does not cover its channel's frequency range."""
        out = []
        for c in self.channels:
            cal = c.calibration
            if cal is not None and not cal.covers(*c.frequency_hz):
                out.append(f"the calibration of {c.actuator} covers {cal.frequencies[0]:g}-{cal.frequencies[-1]:g} Hz, "
                           f"not its declared range {c.frequency_hz[0]:g}-{c.frequency_hz[1]:g} Hz")
        return out

    def check_output(self, devices: Sequence[Mapping], hostapis: Sequence[Mapping]) -> int:
        """The PortAudio index of the configured output (sounddevice's `query_devices()` and
        `query_hostapis()` passed in); AudioConfigError names what is wrong."""
        apis = {i: a["name"] for i, a in enumerate(hostapis)}
        wanted_api = self.host_api.lower()
        on_api = [(i, d) for i, d in enumerate(devices)
                  if wanted_api in apis.get(d["hostapi"], "").lower() and d["max_output_channels"] > 0]
        if not any(wanted_api in name.lower() for name in apis.values()):
            raise AudioConfigError(f"unknown host API {self.host_api!r}: PortAudio here has "
                                   f"{', '.join(repr(name) for name in apis.values()) or 'none'}")
        if not on_api:
            raise AudioConfigError(f"unknown output device {self.output!r}: host API {self.host_api!r} has no "
                                   "output device now (is its server running?)")
        exact = [(i, d) for i, d in on_api if d["name"] == self.output]
        partial = [(i, d) for i, d in on_api if self.output.lower() in d["name"].lower()]
        found = exact or partial
        if len(found) != 1:
            names = ", ".join(repr(d["name"]) for _, d in on_api)
            what = "unknown output device" if not found else "ambiguous output device"
            raise AudioConfigError(f"{what} {self.output!r} on {self.host_api}; its outputs: {names}")
        index, device = found[0]
        if self.outputs > device["max_output_channels"]:
            beyond = [c.actuator for c in self.channels if c.channel > device["max_output_channels"]]
            raise AudioConfigError(f"channel {self.outputs} ({', '.join(beyond)}) is beyond the "
                                   f"{device['max_output_channels']} output channels of {device['name']!r}")
        return index

    @classmethod
    def from_dict(cls, data: Mapping, where: str) -> AudioConfig:
        allowed = {"output", "host_api", "jack_server", "sample_rate", "block", "ramp_ms", "channel"}
        if not isinstance(data, Mapping):
            raise AudioConfigError(f"{where}: audio must be a table")
        unknown = set(data) - allowed
        if unknown:
            raise AudioConfigError(f"{where}: unknown key(s) {sorted(unknown)}; allowed: {', '.join(sorted(allowed))}")
        tables = data.get("channel", [])
        if not isinstance(tables, list) or not tables:
            raise AudioConfigError(f"{where}: no [[device.audio.channel]] tables")
        channels = []
        for i, t in enumerate(tables):
            here = f"{where} channel #{i + 1}"
            allowed_ch = {"actuator", "channel", "gain", "peak", "frequency_hz", "calibration"}
            if not isinstance(t, Mapping) or set(t) - allowed_ch or not {"actuator", "channel"} <= set(t):
                raise AudioConfigError(f"{here}: needs actuator and channel; allowed keys: {', '.join(sorted(allowed_ch))}")
            try:
                band = t.get("frequency_hz", (20.0, 1000.0))
                if len(band) != 2:
                    raise AudioConfigError("frequency_hz must be [low, high]")
                channels.append(AudioChannel(
                    actuator=str(t["actuator"]), channel=t["channel"], gain=float(t.get("gain", 1.0)),
                    peak=float(t.get("peak", 1.0)), frequency_hz=(float(band[0]), float(band[1])),
                    calibration=Calibration.from_dict(t["calibration"], here) if "calibration" in t else None))
            except AudioConfigError as exc:
                raise AudioConfigError(str(exc) if str(exc).startswith(where) else f"{here}: {exc}") from None
            except (TypeError, ValueError) as exc:
                raise AudioConfigError(f"{here}: {exc}") from None
        try:
            server = data.get("jack_server")
            return cls(output=str(data.get("output", "")), host_api=str(data.get("host_api", "")),
                       channels=tuple(channels), sample_rate=int(data.get("sample_rate", 48_000)),
                       block=int(data.get("block", 64)), ramp_ms=float(data.get("ramp_ms", 2.0)),
                       jack_server=None if server is None else str(server))
        except AudioConfigError as exc:
            raise AudioConfigError(f"{where}: {exc}") from None
        except (TypeError, ValueError) as exc:
            raise AudioConfigError(f"{where}: {exc}") from None
