"""Device-independent tactile cues (what scenarios emit; device adapters encode them).

Scenarios never produce bytes or device commands: they say "tilt toward 90 degrees at 100 %" or
"pulse 50 ms on / 200 ms off", and a device profile decides how (or whether) to show it.
Cues are frozen, comparable values, so the loop detects a change with `!=`. Units are in the
field names. Ranges are checked on construction (a bad cue is a bug in a scenario).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import ClassVar


def _check(name: str, value: float, low: float, high: float) -> None:
    if not (math.isfinite(value) and low <= value <= high):
        raise ValueError(f"{name} must be in [{low}, {high}], got {value!r}")


@dataclass(frozen=True)
class PulseTrain:
    """Bursts of vibration: t_on ms on, t_off ms off (spec.md PWM; FingerTac LRAs at 235 Hz)."""
    kind: ClassVar[str] = "pulse_train"
    t_on_ms: float = 50.0
    t_off_ms: float = 200.0
    intensity_pct: float = 100.0
    carrier_hz: float | None = None

    def __post_init__(self) -> None:
        _check("t_on_ms", self.t_on_ms, 0.0, 60_000.0)
        _check("t_off_ms", self.t_off_ms, 0.0, 60_000.0)
        _check("intensity_pct", self.intensity_pct, 0.0, 100.0)
        if self.carrier_hz is not None:
            _check("carrier_hz", self.carrier_hz, 1.0, 2_000.0)


@dataclass(frozen=True)
class Vibration:
    """Continuous vibration."""
    kind: ClassVar[str] = "vibration"
    intensity_pct: float = 100.0
    carrier_hz: float | None = None

    def __post_init__(self) -> None:
        _check("intensity_pct", self.intensity_pct, 0.0, 100.0)
        if self.carrier_hz is not None:
            _check("carrier_hz", self.carrier_hz, 1.0, 2_000.0)


@dataclass(frozen=True)
class Texture:
    """Fine roughness as a periodic signal: period in µs, duty cycle (spec.md Scenario 2)."""
    kind: ClassVar[str] = "texture"
    period_us: float = 4000.0
    duty: float = 0.5
    intensity_pct: float = 100.0

    def __post_init__(self) -> None:
        _check("period_us", self.period_us, 100.0, 1_000_000.0)
        _check("duty", self.duty, 0.0, 1.0)
        _check("intensity_pct", self.intensity_pct, 0.0, 100.0)


@dataclass(frozen=True)
class Tilt:
    """FerroVibe-style tilt: 0 = front of the fingerpad, 90 = right, 180 = back, 270 = left."""
    kind: ClassVar[str] = "tilt"
    direction_deg: float = 0.0
    magnitude_pct: float = 100.0

    def __post_init__(self) -> None:
        _check("direction_deg", self.direction_deg, 0.0, 360.0)
        _check("magnitude_pct", self.magnitude_pct, 0.0, 100.0)


@dataclass(frozen=True)
class Temperature:
    kind: ClassVar[str] = "temperature"
    celsius: float = 32.0

    def __post_init__(self) -> None:
        _check("celsius", self.celsius, 0.0, 50.0)


@dataclass(frozen=True)
class Friction:
    kind: ClassVar[str] = "friction"
    coefficient: float = 0.5

    def __post_init__(self) -> None:
        _check("coefficient", self.coefficient, 0.0, 5.0)


Cue = PulseTrain | Vibration | Texture | Tilt | Temperature | Friction


_FIELDS = {cls: tuple(f.name for f in fields(cls)) for cls in (PulseTrain, Vibration, Texture, Tilt, Temperature, Friction)}


def cue_to_wire(cue: Cue) -> dict:
    """The cue as a protocol map: {"kind": ..., fields...} with None fields left out.

    Called in the loop for every published frame: plain getattr, not dataclasses.asdict
    (which deep-copies and costs ~4 µs per cue)."""
    body = {"kind": cue.kind}
    for name in _FIELDS[type(cue)]:
        value = getattr(cue, name)
        if value is not None:
            body[name] = value
    return body


def tilt_direction(angle_deg: float) -> float:
    """Normalise a direction to [0, 360)."""
    d = angle_deg % 360.0
    return 0.0 if d >= 360.0 else d + 0.0  # + 0.0 turns -0.0 into 0.0
