"""A modelled 1-DoF impedance-type force device pushed against a virtual wall (the stiffness sweep
of `viestac bench stability`).

Theory of operation
-------------------
The device is a mass ``m`` with physical damping ``b`` (its own friction and motor/amplifier
damping). The user pushes it with a constant force toward a wall; the servo loop samples its
position every T = 1/f s, runs the REAL god-object (server/core/haptics/god_object.py) on a Plane body
of stiffness K to get the spring force K (proxy - HIP), and holds that force until the next sample
(zero-order hold). Between samples the force is constant, so m v' = -b v + F has the closed form

    v(t) = F/b + (v0 - F/b) e^(-t b/m)
    x(t) = x0 + (F/b) t + (v0 - F/b) (m/b) (1 - e^(-t b/m)),

used to advance the device exactly (no integration error that could add or remove energy and
move the boundary). The hold is what makes a stiff sampled wall active: on average the force
lags the position by T/2, which acts as a negative damping K T/2. Colgate & Schenkel (1997)
state the passivity condition b > K T / 2 (with no virtual damping), i.e. K < 2 b / T; the
sweep measures where the coupled device actually starts to oscillate.

The defaults (m = 0.05 kg, b = 1.0 N s/m, user force 1 N) are ASSUMPTIONS in the range of a
desktop impedance device (CHAI3D's defaults list 4-30 N s/m of "max damping" and 400-5000 N/m
of stiffness for such devices, docs/reference.md "Stability"); the device is a model, not a
datasheet.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import exp, expm1, log

from server.core.haptics.god_object import GodObject
from server.core.haptics.primitives import Body, Plane
from server.core.numbers import is_finite_number

WALL_SIZE = (1.0, 1.0)  # metres: far wider than any motion of the 1-DoF device
GROWTH_FLOOR = 0.01  # below 1 % of the static penetration F/K an oscillation counts as gone
START_HEIGHT_M = 0.002  # the device starts 2 mm above the wall...
START_VELOCITY_M_S = -0.05  # ...moving toward it


def _positive(value: float, what: str) -> float:
    if not is_finite_number(value) or value <= 0:
        raise ValueError(f"{what} must be a finite number > 0, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class ForceDevice:
    """1-DoF mass-damper driven by a force held constant over each servo period."""

    mass_kg: float = 0.05
    damping_n_s_per_m: float = 1.0

    def __post_init__(self) -> None:
        _positive(self.mass_kg, "mass_kg")
        _positive(self.damping_n_s_per_m, "damping_n_s_per_m")

    def advance(self, x: float, v: float, force: float, dt: float) -> tuple[float, float]:
        """Exact state after dt s under the constant force (closed form, module docstring)."""
        b = self.damping_n_s_per_m
        rate = b / self.mass_kg
        v_inf = force / b
        decay = -expm1(-rate * dt)  # 1 - e^(-rate dt), accurate for small rate dt
        return x + v_inf * dt + (v - v_inf) * decay / rate, v_inf + (v - v_inf) * (1.0 - decay)

    def free_position(self, x0: float, v0: float, force: float, t: float) -> float:
        """The analytic x(t) under a constant force for all t (the test oracle of ``advance``)."""
        b = self.damping_n_s_per_m
        v_inf = force / b
        return x0 + v_inf * t + (v0 - v_inf) * (self.mass_kg / b) * (1.0 - exp(-t * b / self.mass_kg))

    def passivity_bound(self, rate_hz: float) -> float:
        """Colgate & Schenkel's largest passive wall stiffness 2 b / T (N/m) at this servo rate."""
        return 2.0 * self.damping_n_s_per_m * rate_hz


@dataclass(frozen=True)
class WallTrace:
    """The device at every servo sample: position (m, the wall's surface is z = 0, free space
    above), the god-object's contact flag, and the force it returned (N, +z pushes out)."""

    rate_hz: float
    positions: tuple[float, ...]
    contacts: tuple[bool, ...]
    forces: tuple[float, ...]


def simulate_wall(device: ForceDevice, stiffness: float, rate_hz: float, *, push_n: float = 1.0,
                  duration_s: float = 3.0, x0: float = START_HEIGHT_M,
                  v0: float = START_VELOCITY_M_S) -> WallTrace:
    """The device starting at x0 (above the wall) with velocity v0, pushed down by ``push_n``,
    coupled to a god-object wall of ``stiffness`` sampled at ``rate_hz`` for ``duration_s``."""
    stiffness = _positive(stiffness, "stiffness")
    rate_hz = _positive(rate_hz, "rate_hz")
    push_n = _positive(push_n, "push_n")
    wall = [Body("wall", Plane(WALL_SIZE), stiffness_n_per_m=stiffness)]
    god = GodObject(0.0)  # point proxy: the device's HIP is a point
    dt = 1.0 / rate_hz
    x, v = float(x0), float(v0)
    positions, contacts, forces = [], [], []
    for _ in range(round(duration_s * rate_hz)):
        step = god.step(wall, (0.0, 0.0, x))
        positions.append(x)
        contacts.append(bool(step.contacts))
        forces.append(step.force[2])
        x, v = device.advance(x, v, step.force[2] - push_n, dt)
    return WallTrace(rate_hz, tuple(positions), tuple(contacts), tuple(forces))


@dataclass(frozen=True)
class Oscillation:
    """How the coupled device behaves after settling, from the last two windows of a trace."""

    early_p2p: float  # peak-to-peak position (m) in the window before the last
    late_p2p: float  # ... in the last window
    relative_p2p: float  # late_p2p / (F/K): the ripple against the static penetration
    bounces: int  # contact losses (touching -> free) in the two windows
    growth_per_s: float | None  # ln(late/early) / window; None when both are ~0 (at rest)
    oscillating: bool

    def to_dict(self) -> dict:
        return {"early_p2p_m": self.early_p2p, "late_p2p_m": self.late_p2p, "relative_p2p": self.relative_p2p,
                "bounces": self.bounces, "growth_per_s": self.growth_per_s, "oscillating": self.oscillating}


def measure_oscillation(trace: WallTrace, static_penetration: float, window_s: float) -> Oscillation:
    """Oscillating = the device still loses contact (bounces) in the last two windows, or the
    ripple is not dying out: late peak-to-peak >= early peak-to-peak while above GROWTH_FLOOR of
    the static penetration. A decaying ringing is stable (it is only slow near the boundary)."""
    n = round(window_s * trace.rate_hz)
    if n < 2 or 2 * n > len(trace.positions):
        raise ValueError(f"window of {window_s} s needs at least {2 * max(n, 2)} samples, "
                         f"the trace has {len(trace.positions)}")
    early, late = trace.positions[-2 * n:-n], trace.positions[-n:]
    early_p2p, late_p2p = max(early) - min(early), max(late) - min(late)
    touching = trace.contacts[-2 * n:]
    bounces = sum(1 for a, b in zip(touching, touching[1:]) if a and not b)
    floor = GROWTH_FLOOR * static_penetration
    growth = None
    if late_p2p > 0.0 and early_p2p > 0.0:
        growth = log(late_p2p / early_p2p) / window_s
    oscillating = bounces > 0 or (late_p2p > floor and late_p2p >= early_p2p)
    return Oscillation(early_p2p, late_p2p, late_p2p / static_penetration, bounces, growth, oscillating)


def wall_cell(device: ForceDevice, stiffness: float, rate_hz: float, *, push_n: float, duration_s: float,
              window_s: float) -> Oscillation:
    """One (stiffness, rate) cell: simulate and measure."""
    trace = simulate_wall(device, stiffness, rate_hz, push_n=push_n, duration_s=duration_s)
    return measure_oscillation(trace, push_n / stiffness, window_s)


def refine_boundary(device: ForceDevice, rate_hz: float, k_stable: float, k_oscillating: float, *,
                    iterations: int, push_n: float, duration_s: float, window_s: float) -> tuple[float, float]:
    """Bisect (in log K) between a stable and an oscillating stiffness; returns the tightened
    (largest stable K found, smallest oscillating K found)."""
    lo, hi = k_stable, k_oscillating
    for _ in range(iterations):
        mid = (lo * hi) ** 0.5
        if wall_cell(device, mid, rate_hz, push_n=push_n, duration_s=duration_s, window_s=window_s).oscillating:
            hi = mid
        else:
            lo = mid
    return lo, hi
