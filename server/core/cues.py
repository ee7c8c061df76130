"""Device-independent tactile cues (what scenarios emit; device adapters encode them).

Scenarios never produce bytes or device commands: they say "tilt toward 90 degrees at 100 %" or
"pulse 50 ms on / 200 ms off", and a device profile decides how (or whether) to show it.
Cues are frozen, comparable values, so the loop detects a change with `!=`. Units are in the
field names. Each cue class declares the valid range of every field in `RANGES`, checked on
construction (a bad cue is a bug in a scenario); None means "not given" for optional fields.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import ClassVar

from server.core.numbers import is_finite_number


class _Ranged:
    RANGES: ClassVar[dict[str, tuple[float, float]]] = {}

    def __post_init__(self) -> None:
        for name, (low, high) in self.RANGES.items():
            value = getattr(self, name)
            if value is None or (type(value) is float and low <= value <= high):
                continue  # a float within the (finite) range is finite; NaN fails the compare
            if not (is_finite_number(value) and low <= value <= high):
                raise ValueError(f"{type(self).__name__}.{name} must be in [{low}, {high}], got {value!r}")


@dataclass(frozen=True)
class PulseTrain(_Ranged):
    """Bursts of vibration: t_on ms on, t_off ms off (thesis §3.1: FingerTac LRAs at 235 Hz)."""
    kind: ClassVar[str] = "pulse_train"
    RANGES: ClassVar = {"t_on_ms": (0.0, 60_000.0), "t_off_ms": (0.0, 60_000.0), "intensity_pct": (0.0, 100.0),
                        "carrier_hz": (1.0, 2_000.0), "duration_ms": (0.0, 60_000.0)}
    t_on_ms: float = 50.0
    t_off_ms: float = 200.0
    intensity_pct: float = 100.0
    carrier_hz: float | None = None
    duration_ms: float | None = None  # a stimulus of exactly this length from its onset (see Vibration)


@dataclass(frozen=True)
class Vibration(_Ranged):
    """Continuous vibration. With `duration_ms` it is a timed stimulus (a psychophysics interval):
    a device that keeps its own clock (an audio tactor) plays exactly that long from the onset,
    whatever the link's delay to the off; the others follow the scenario, which emits the cue for
    that long on the tick clock."""
    kind: ClassVar[str] = "vibration"
    RANGES: ClassVar = {"intensity_pct": (0.0, 100.0), "carrier_hz": (1.0, 2_000.0), "duration_ms": (0.0, 60_000.0)}
    intensity_pct: float = 100.0
    carrier_hz: float | None = None
    duration_ms: float | None = None


@dataclass(frozen=True)
class Texture(_Ranged):
    """Fine roughness as a periodic signal: period in µs, duty cycle (thesis §4.1.2)."""
    kind: ClassVar[str] = "texture"
    RANGES: ClassVar = {"period_us": (100.0, 1_000_000.0), "duty": (0.0, 1.0), "intensity_pct": (0.0, 100.0)}
    period_us: float = 4000.0
    duty: float = 0.5
    intensity_pct: float = 100.0


@dataclass(frozen=True)
class Tilt(_Ranged):
    """FerroVibe-style tilt: 0 = front of the fingerpad, 90 = right, 180 = back, 270 = left. Not
    the contact angle: the contact-angle task sends (−angle) mod 360, so −10° is 10 (docs/data.md)."""
    kind: ClassVar[str] = "tilt"
    RANGES: ClassVar = {"direction_deg": (0.0, 360.0), "magnitude_pct": (0.0, 100.0)}
    direction_deg: float = 0.0
    magnitude_pct: float = 100.0


@dataclass(frozen=True)
class Stiffness(_Ranged):
    """How hard the touched object is (Table 2.2 "stiffness"). `k_n_per_m` is the spring constant;
    `relative` places it between the softest (0) and stiffest (1) object of the task, which is what
    a device that encodes stiffness as vibration shows (thesis §4.1.3: pulse rate)."""
    kind: ClassVar[str] = "stiffness"
    RANGES: ClassVar = {"k_n_per_m": (0.0, 1e6), "relative": (0.0, 1.0)}
    k_n_per_m: float = 100.0
    relative: float = 1.0


@dataclass(frozen=True)
class Temperature(_Ranged):
    kind: ClassVar[str] = "temperature"
    RANGES: ClassVar = {"celsius": (0.0, 50.0)}
    celsius: float = 32.0


@dataclass(frozen=True)
class Friction(_Ranged):
    kind: ClassVar[str] = "friction"
    RANGES: ClassVar = {"coefficient": (0.0, 5.0)}
    coefficient: float = 0.5


@dataclass(frozen=True)
class Stop(_Ranged):
    """Every actuator off now, whatever else the tick asks for (same as emitting no cue at all,
    but explicit, so a scenario can say "silence" next to cues it still reports)."""
    kind: ClassVar[str] = "stop"


Cue = PulseTrain | Vibration | Texture | Tilt | Stiffness | Temperature | Friction | Stop
CUE_CLASSES = (PulseTrain, Vibration, Texture, Tilt, Stiffness, Temperature, Friction, Stop)
CUE_KINDS = {cls.kind: cls for cls in CUE_CLASSES}
_FIELDS = {cls: tuple(f.name for f in fields(cls)) for cls in CUE_CLASSES}


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


def cue_from_wire(body: dict) -> Cue:
    """The inverse of cue_to_wire; ValueError (naming the problem) for an unknown kind or field."""
    if not isinstance(body, dict) or body.get("kind") not in CUE_KINDS:
        raise ValueError(f"unknown cue kind {body.get('kind') if isinstance(body, dict) else body!r}; "
                         f"known: {', '.join(CUE_KINDS)}")
    cls = CUE_KINDS[body["kind"]]
    params = {k: v for k, v in body.items() if k != "kind"}
    unknown = set(params) - set(_FIELDS[cls])
    if unknown:
        raise ValueError(f"{cls.kind} cue has no field(s) {', '.join(sorted(unknown))}")
    return cls(**params)


def tilt_direction(angle_deg: float) -> float:
    """Normalise a direction to [0, 360)."""
    d = angle_deg % 360.0
    return 0.0 if d >= 360.0 else d + 0.0  # + 0.0 turns -0.0 into 0.0
