"""Tactile guidance laws of the positioning tasks (thesis §4.2.1-4.2.4; docs/scenarios.md).

Pure functions of distances (and one small state machine for the time-variant patterns), shared
by the positioning, peg-in-hole and hot-wire scenarios. A law answers with the PWM pause t_off
in milliseconds (t_on stays fixed, intensity constant unless the law says otherwise), or `None`
for "no vibration"; `0.0` means no pause, i.e. continuous vibration.

Depth d = |object.x − target.x| (the axis the orthographic side view hides); the cue zone is the
ball of radius B (2 by default) around the target.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from server.core.cues import PulseTrain, Tilt, Vibration

BOUNDARY = 2.0          # B: cue zone radius around the target
TARGET_THRESHOLD = 0.05  # "at target": within this on every axis (default)
HOLD_OFFSET = 0.1       # time-variant patterns: cue only within this depth after the first reach
T_ON_MS = 50.0          # our pulse default (docs/reference.md "Devices")

MODES = ("continuous-at-target", "none-at-target")
PATTERNS = ("P1", "P2", "P3", "P4")
P2_FORMS = ("A", "B")   # A: sine curve fit (4.2); B: piecewise linear (4.3-4.5), used in the study


def mode_t_off(mode: str, depth: float, in_zone: bool, boundary: float = BOUNDARY,
               threshold: float = TARGET_THRESHOLD) -> float | None:
    """Algorithm 3. continuous-at-target: t_off = 500·d, continuous inside the threshold;
    none-at-target: t_off = 500·(B − d), silent inside the threshold. Nothing outside the zone."""
    if mode not in MODES:
        raise ValueError(f"vibration mode must be one of {', '.join(MODES)}, got {mode!r}")
    if not in_zone:
        return None
    if mode == "continuous-at-target":
        return 0.0 if depth <= threshold else 500.0 * depth
    return None if depth <= threshold else 500.0 * (boundary - depth)


def p1_t_off(depth: float) -> float:
    """Pattern 1, linear time-invariant: t_off = 500·d."""
    return 500.0 * depth


def p2_t_off(depth: float, form: str = "B", boundary: float = BOUNDARY) -> float:
    """Pattern 2, non-linear time-invariant. Form A: x = d/B, t_off = 500·(sin 6x + 6x)/6.
    Form B (piecewise linear, continuous): 500d/3 up to 0.3, (500d + 150)/6 up to 0.9,
    (4000d − 2500)/11 up to 2 (0 → 0, 0.3 → 50, 0.9 → 100, 2 → 500)."""
    if form == "A":
        x = min(1.0, depth / boundary)
        return 500.0 * (math.sin(6.0 * x) + 6.0 * x) / 6.0
    if form != "B":
        raise ValueError(f"P2 form must be one of {', '.join(P2_FORMS)}, got {form!r}")
    if depth <= 0.3:
        return 500.0 * depth / 3.0
    if depth <= 0.9:
        return (500.0 * depth + 150.0) / 6.0
    return (4000.0 * depth - 2500.0) / 11.0


@dataclass
class PatternGuide:
    """Patterns P1-P4 for one trial. P3/P4 are P1/P2 until the object first reaches the target;
    from then on the cue is t_off = 1000·d within HOLD_OFFSET of the target depth and nothing
    beyond it, to help hold the position instead of overshooting (thesis eq. 4.6)."""
    pattern: str = "P1"
    p2_form: str = "B"
    boundary: float = BOUNDARY
    hold_offset: float = HOLD_OFFSET
    reached: bool = False

    def __post_init__(self) -> None:
        if self.pattern not in PATTERNS:
            raise ValueError(f"pattern must be one of {', '.join(PATTERNS)}, got {self.pattern!r}")
        if self.p2_form not in P2_FORMS:
            raise ValueError(f"P2 form must be one of {', '.join(P2_FORMS)}, got {self.p2_form!r}")

    def t_off(self, depth: float, in_zone: bool, at_target: bool) -> float | None:
        """The pause for this tick; `at_target` (every axis within the threshold) latches the
        time-variant switch."""
        if at_target:
            self.reached = True
        if not in_zone:
            return None
        if self.pattern in ("P3", "P4") and self.reached:
            return 1000.0 * depth if depth <= self.hold_offset else None
        if self.pattern in ("P1", "P3"):
            return p1_t_off(depth)
        return p2_t_off(depth, self.p2_form, self.boundary)


def pulse_cue(t_off_ms: float | None, t_on_ms: float = T_ON_MS, intensity_pct: float = 100.0):
    """The cue of a t_off law: nothing, continuous vibration (t_off 0) or a pulse train."""
    if t_off_ms is None:
        return None
    if t_off_ms <= 0.0:
        return Vibration(intensity_pct)
    return PulseTrain(t_on_ms, t_off_ms, intensity_pct)


# -- 3-DoF guidance on the FerroVibe (§4.2.3) ---------------------------------------------------

# (horizontal, depth) → tilt direction. Horizontal: the target is left (-1) or right (+1) of the
# object; depth: the target is in front (-1: farther from the viewer, the hand moves forward) or
# behind (+1: overshoot). 0 = aligned within the threshold.
_TILTS = {(-1, 0): 90.0, (1, 0): 270.0, (0, -1): 180.0, (0, 1): 0.0,
          (-1, -1): 135.0, (1, -1): 225.0, (-1, 1): 45.0, (1, 1): 315.0}


def _side(delta: float, threshold: float) -> int:
    return 0 if abs(delta) <= threshold else (1 if delta > 0 else -1)


def guidance_tilt(obj, target, threshold: float = TARGET_THRESHOLD) -> float | None:
    """Tilt direction toward the target in the horizontal (y) and depth (x) axes: target left →
    90° (pushed from the right), right → 270°, in front → 180° (hits the back), behind
    (overshoot) → 0° (hits the front), both off-axis → the diagonal between them; None when
    aligned in both."""
    key = (_side(target[1] - obj[1], threshold), _side(target[0] - obj[0], threshold))
    return _TILTS.get(key)


def vertical_t_off(dz: float, boundary: float = BOUNDARY, min_t_off_ms: float = 50.0) -> float | None:
    """Vertical distance as pulse rate, rising toward the target height: t_off = 500·|dz|, never
    below min_t_off_ms (the maximum rate, also played at the target); nothing beyond the zone."""
    dz = abs(dz)
    if dz > boundary:
        return None
    return round(max(min_t_off_ms, 500.0 * dz), 9)  # 500·0.2 reads 100, not 99.99999999999997


def guidance_cues(obj, target, *, threshold: float = TARGET_THRESHOLD, boundary: float = BOUNDARY,
                  t_on_ms: float = T_ON_MS, min_t_off_ms: float = 50.0) -> tuple:
    """The FerroVibe's 3-DoF cues: a tilt for y/x and a pulse train for z; at the target only the
    pulse train at the maximum rate."""
    distance = math.dist(obj, target)
    if distance > boundary:
        return ()
    at_target = all(abs(o - t) <= threshold for o, t in zip(obj, target))
    rate = PulseTrain(t_on_ms, min_t_off_ms if at_target else vertical_t_off(target[2] - obj[2], boundary,
                                                                             min_t_off_ms))
    direction = None if at_target else guidance_tilt(obj, target, threshold)
    return (rate,) if direction is None else (Tilt(direction, 100.0), rate)


# -- peg-in-hole and hot wire (§4.2.4) ----------------------------------------------------------

@dataclass(frozen=True)
class LinearCue:
    """Intensity and pulse rate linear in a distance between `near` and `far`: at `near` the
    strongest cue (intensity 100 %, t_off 0: continuous), at `far` the weakest (intensity
    `min_intensity_pct`, t_off `max_t_off_ms`); `rising` flips the direction."""
    near: float
    far: float
    max_t_off_ms: float = 500.0
    min_intensity_pct: float = 30.0  # below ~30 % an LRA burst is hard to feel (default)
    t_on_ms: float = T_ON_MS

    def cue(self, distance: float, strongest_near: bool = True):
        if not self.near <= distance <= self.far:
            return None
        f = (distance - self.near) / (self.far - self.near)  # 0 at near, 1 at far
        strength = 1.0 - f if strongest_near else f
        intensity = self.min_intensity_pct + (100.0 - self.min_intensity_pct) * strength
        t_off = self.max_t_off_ms * (1.0 - strength)
        return Vibration(intensity) if t_off <= 0.0 else PulseTrain(self.t_on_ms, t_off, intensity)


def peg_cue(distance: float, boundary: float = BOUNDARY, reverse: bool = False,
            threshold: float = TARGET_THRESHOLD, t_on_ms: float = T_ON_MS):
    """Peg-in-hole: intensity and pulse rate rise linearly as the object nears the nearest hole,
    nothing beyond the boundary; reverse: they fall toward the hole and stop at it."""
    if distance > boundary:
        return None
    if reverse:
        return None if distance <= threshold else \
            LinearCue(threshold, boundary, t_on_ms=t_on_ms).cue(distance, strongest_near=False)
    return LinearCue(0.0, boundary, t_on_ms=t_on_ms).cue(distance)


def hot_wire_cue(deviation: float, threshold: float, max_distance: float, t_on_ms: float = T_ON_MS):
    """Hot wire: nothing within the allowed threshold; beyond it intensity and pulse rate rise
    with the deviation up to `max_distance`; beyond that the cue stops."""
    if deviation <= threshold or deviation > max_distance:
        return None
    return LinearCue(threshold, max_distance, t_on_ms=t_on_ms).cue(deviation, strongest_near=False)
