"""Cue encoder: a tick's device-independent cues → the commands one device profile can show.

Pure and cheap (called whenever the cue set changes). The result is the complete desired state
of every layer the device has (device-protocol.md §2: pattern, tilt, temperature, friction), so
a layer with no cue gets its off value and the link's latest-wins slots do the rest. A cue the
profile cannot show is never dropped silently: it comes back as a `Refusal` with a reason that
the scenario (TickContext.refusals) and the console (/api/devices, `viestac devices`) show.

Encodings (thesis Table 2.2: "!" direct, "(!)" encoded as vibration):
- PulseTrain → pattern `pulse` (needs the pulse cap); Vibration → pattern `continuous`.
- Tilt: direct → SET_TILT; (!) → continuous vibration whose intensity is the tilt magnitude
  (the direction is lost: a 1-DoF vibrator cannot point).
- Texture: direct → pattern `texture` (on for duty·P, off for the rest: FerroVibe tilts for P/2,
  flat for P/2, thesis §4.1.2); (!) → continuous vibration at the texture's frequency 1/P.
- Stiffness: (!) → pulse train, t_on fixed, pulse rate linear in `relative` from 1 Hz (softest) to
  10 Hz (stiffest), t_off = 1000/rate − t_on (thesis §4.1.3 and our defaults in
  `StiffnessEncoding`); direct → refused, protocol v1 has no normal-force command.
- Temperature, Friction: direct only.
- Stop: every layer off, whatever else the tick asks for.
Two cues that need the same layer in one tick: the first one (scenario order) wins, the other is
refused as a conflict.
"""

from __future__ import annotations

from dataclasses import dataclass

from server.core.cues import Cue, Friction, PulseTrain, Stiffness, Stop, Temperature, Texture, Tilt, Vibration
from devices.messages import ALL_CHANNELS, SetFriction, SetPattern, SetTemperature, SetTilt
from devices.profiles import DeviceProfile, Display

NEUTRAL_SKIN_C = 32.0  # a thermal display at rest shows skin temperature, not "off"

_DIMENSION = {Tilt: "macro_roughness", Texture: "fine_roughness", Stiffness: "stiffness", Temperature: "temperature",
              Friction: "friction"}


# The last PulseTrain cue encoded and its command. Every device of a rig encodes the very same
# cue objects each tick, and a cue and a message are immutable, so the next device reuses the
# command (one tuple, rebound at once: safe across threads).
_last_pulse: tuple[PulseTrain | None, SetPattern | None] = (None, None)


def _pulse_pattern(cue: PulseTrain) -> SetPattern:
    global _last_pulse
    last_cue, command = _last_pulse
    if last_cue is not cue:
        command = SetPattern.pulse(ALL_CHANNELS, cue.t_on_ms, cue.t_off_ms, cue.intensity_pct, cue.carrier_hz or 0,
                                   in_range=True)  # the cue checked its ranges when it was made
        _last_pulse = (cue, command)
    return command


@dataclass(frozen=True)
class StiffnessEncoding:
    """Stiffness as vibration (thesis §4.1.3; docs/reference.md "Devices"): bursts of t_on_ms whose
    rate rises linearly from rate_hz[0] (softest) to rate_hz[1] (stiffest)."""
    t_on_ms: float = 50.0
    rate_hz: tuple[float, float] = (1.0, 10.0)
    intensity_pct: float = 100.0

    def __post_init__(self) -> None:
        low, high = self.rate_hz
        if not (0.0 < low <= high and self.t_on_ms > 0.0 and 1000.0 / high >= self.t_on_ms):
            raise ValueError("stiffness encoding needs 0 < rate_low <= rate_high and t_on <= 1000/rate_high ms")

    def pulse_rate_hz(self, relative: float) -> float:
        low, high = self.rate_hz
        return low + (high - low) * relative

    def t_off_ms(self, relative: float) -> float:
        return 1000.0 / self.pulse_rate_hz(relative) - self.t_on_ms


@dataclass(frozen=True)
class Refusal:
    device: str            # configured device name
    model: str
    cue: str               # cue kind, e.g. "tilt"
    dimension: str | None  # Table 2.2 dimension, None for plain vibration cues
    code: str              # "not_displayed" | "no_capability" | "conflict"
    reason: str            # one sentence for people

    def to_dict(self) -> dict:
        return {"device": self.device, "model": self.model, "cue": self.cue, "dimension": self.dimension,
                "code": self.code, "reason": self.reason}


@dataclass(frozen=True)
class Encoding:
    commands: dict[str, object]   # layer name → SET_* message for ALL_CHANNELS
    refusals: tuple[Refusal, ...]


class CueEncoder:
    def __init__(self, profile: DeviceProfile, device: str | None = None,
                 stiffness: StiffnessEncoding = StiffnessEncoding()):
        self.profile = profile
        self.device = device or profile.model
        self.stiffness = stiffness
        caps = profile.caps
        self.off: dict[str, object] = {}
        if {"pulse", "continuous", "texture"} & caps:
            self.off["pattern"] = SetPattern.off(ALL_CHANNELS)
        if "tilt" in caps:
            self.off["tilt"] = SetTilt.flat(ALL_CHANNELS)
        if "temperature" in caps:
            self.off["temperature"] = SetTemperature.from_celsius(ALL_CHANNELS, NEUTRAL_SKIN_C)
        if "friction" in caps:
            self.off["friction"] = SetFriction.from_coefficient(ALL_CHANNELS, 0.0)

    def encode(self, cues: tuple[Cue, ...] | list[Cue]) -> Encoding:
        commands = dict(self.off)
        for c in cues:
            if isinstance(c, Stop):
                return Encoding(commands, ())
        claimed: dict[str, str] = {}
        refusals: list[Refusal] = []
        for cue in cues:
            layer_and_command = self._encode_one(cue)
            if isinstance(layer_and_command, Refusal):
                refusals.append(layer_and_command)
                continue
            layer, command = layer_and_command
            if layer in claimed:
                refusals.append(self._refuse(cue, "conflict",
                                             f"the {layer} layer already shows the {claimed[layer]} cue this tick"))
                continue
            claimed[layer] = cue.kind
            commands[layer] = command
        return Encoding(commands, tuple(refusals))

    def _refuse(self, cue: Cue, code: str, why: str) -> Refusal:
        dimension = _DIMENSION.get(type(cue))
        return Refusal(self.device, self.profile.model, cue.kind, dimension, code,
                       f"{self.device} ({self.profile.model}) cannot show the {cue.kind} cue: {why}")

    def _vibration(self, intensity_pct: float, carrier_hz: float) -> tuple[str, object]:
        return "pattern", SetPattern.continuous(ALL_CHANNELS, intensity_pct, carrier_hz)

    def _encode_one(self, cue: Cue) -> tuple[str, object] | Refusal:
        caps = self.profile.caps
        if isinstance(cue, PulseTrain):
            if "pulse" not in caps:
                return self._refuse(cue, "no_capability", "its firmware has no pulse-train command")
            return "pattern", _pulse_pattern(cue)
        if isinstance(cue, Vibration):
            if "continuous" not in caps:
                return self._refuse(cue, "no_capability", "its firmware has no continuous-vibration command")
            return self._vibration(cue.intensity_pct, cue.carrier_hz or 0)
        dimension = _DIMENSION[type(cue)]
        how = self.profile.dimensions[dimension]
        if how is Display.NONE:
            return self._refuse(cue, "not_displayed",
                                f"its profile does not display {dimension.replace('_', '-')} (Table 2.2: -)")
        if isinstance(cue, Tilt):
            if how is Display.DIRECT:
                return "tilt", SetTilt.from_degrees(ALL_CHANNELS, cue.direction_deg, cue.magnitude_pct)
            return self._vibration(cue.magnitude_pct, 0)
        if isinstance(cue, Texture):
            if how is Display.DIRECT:
                return "pattern", SetPattern.texture(ALL_CHANNELS, cue.period_us, cue.duty, cue.intensity_pct)
            return self._vibration(cue.intensity_pct, 1e6 / cue.period_us)
        if isinstance(cue, Stiffness):
            if how is Display.DIRECT:
                return self._refuse(cue, "no_capability", "device protocol v1 has no normal-force command; "
                                    "declare stiffness as shown by vibration in its profile")
            if "pulse" not in caps:
                return self._refuse(cue, "no_capability", "its firmware has no pulse-train command")
            enc = self.stiffness
            return "pattern", SetPattern.pulse(ALL_CHANNELS, enc.t_on_ms, enc.t_off_ms(cue.relative),
                                               enc.intensity_pct, 0)
        if isinstance(cue, Temperature):
            return "temperature", SetTemperature.from_celsius(ALL_CHANNELS, cue.celsius)
        return "friction", SetFriction.from_coefficient(ALL_CHANNELS, cue.coefficient)
