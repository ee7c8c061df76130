"""Scripted sources for demos and tests (`viestac serve --tracker scripted:NAME`).

Each script is a pure function of time (seconds) → points in the scene frame (scene units), so
a demo is the same every run. The scripts know the default scenes' geometry: the contact-angle
dome has radius 0.6 at the origin and the HIP sphere radius 0.06 (scenarios/contact_angle.py).

- `tap`: the index finger touches the dome at −60°, −30°, 0°, 30°, 60° in turn (1.5 s each: an
  approach, 0.6 s pressed 1 cm in, a lift);
- `circle`: the index finger circles 0.1 above the dome's top, never touching it;
- `pinch`: index and thumb close on a point above the dome and open again (2 s period), for the
  two-finger scenarios.
"""

from __future__ import annotations

import math

DOME_RADIUS = 0.6
HIP_RADIUS = 0.06
RATE_HZ = 120.0


def _on_dome(angle_deg: float, radius: float) -> tuple[float, float, float]:
    a = math.radians(angle_deg)
    return (0.0, radius * math.sin(a), radius * math.cos(a))


def tap(t: float) -> dict:
    angles = (-60.0, -30.0, 0.0, 30.0, 60.0)
    k = int(t // 1.5) % len(angles)
    phase = (t % 1.5) / 1.5  # 0..1
    touching = DOME_RADIUS + HIP_RADIUS - 0.01
    away = DOME_RADIUS + HIP_RADIUS + 0.15
    if phase < 0.3:
        r = away + (touching - away) * phase / 0.3
    elif phase < 0.7:
        r = touching
    else:
        r = touching + (away - touching) * (phase - 0.7) / 0.3
    return {"right.index.tip": _on_dome(angles[k], r)}


def circle(t: float) -> dict:
    a = 2 * math.pi * t / 4.0
    z = DOME_RADIUS + HIP_RADIUS + 0.1
    return {"right.index.tip": (0.25 * math.cos(a), 0.25 * math.sin(a), z)}


def pinch(t: float) -> dict:
    gap = 0.08 + 0.12 * (0.5 + 0.5 * math.cos(2 * math.pi * t / 2.0))
    centre = (0.0, 0.0, DOME_RADIUS + 0.3)
    return {"right.index.tip": (centre[0], centre[1] + gap / 2, centre[2]),
            "right.thumb.tip": (centre[0], centre[1] - gap / 2, centre[2]),
            "right.palm": (centre[0] + 0.05, centre[1], centre[2] + 0.12)}


SCRIPTS = {"tap": tap, "circle": circle, "pinch": pinch}


def script(name: str):
    try:
        return SCRIPTS[name]
    except KeyError:
        raise ValueError(f"unknown scripted tracker {name!r}; one of {', '.join(SCRIPTS)}") from None
