"""Sensitivity d′ and criterion (Macmillan & Creelman 2005, Detection Theory: A User's Guide, 2nd ed.).

Rates are corrected log-linearly by default, (count + 0.5) / (trials + 1), for every cell, so a
hit rate of 1 or a false-alarm rate of 0 gives a finite d′ (Hautus 1995, BRMIC 27:46);
`correction="none"` uses the raw rates and refuses 0 and 1.

- yes/no: d′ = z(H) − z(F), c = −(z(H) + z(F)) / 2.
- same–different, the differencing model (Macmillan & Creelman ch. 9; the observer says
  "different" when the difference of the two observations exceeds k in magnitude):
      F = 2·Φ(−k/√2),   H = Φ((d′ − k)/√2) + Φ((−d′ − k)/√2)
  k from F in closed form, d′ from H by root finding (H rises from F at d′ = 0 towards 1).
  H ≤ F gives d′ = 0. (The independent-observation model gives other numbers; not offered.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from scipy.optimize import brentq
from scipy.special import ndtr, ndtri


@dataclass(frozen=True)
class Sensitivity:
    d_prime: float
    criterion: float      # yes/no: c; same–different: k
    hit_rate: float
    false_alarm_rate: float


def _rate(count: float, trials: float, correction: str) -> float:
    if trials <= 0 or not 0 <= count <= trials:
        raise ValueError(f"need 0 ≤ count ≤ trials and trials > 0, got {count} of {trials}")
    if correction == "loglinear":
        return (count + 0.5) / (trials + 1.0)
    if correction != "none":
        raise ValueError(f"unknown correction {correction!r} (loglinear or none)")
    rate = count / trials
    if rate in (0.0, 1.0):
        raise ValueError(f"a rate of {rate:g} has no z score: use the loglinear correction")
    return rate


def yes_no(hits: int, signal_trials: int, false_alarms: int, noise_trials: int,
           correction: str = "loglinear") -> Sensitivity:
    h, f = _rate(hits, signal_trials, correction), _rate(false_alarms, noise_trials, correction)
    zh, zf = float(ndtri(h)), float(ndtri(f))
    return Sensitivity(zh - zf, -(zh + zf) / 2.0, h, f)


def same_different(hits: int, different_trials: int, false_alarms: int, same_trials: int,
                   correction: str = "loglinear") -> Sensitivity:
    """hits: "different" to different pairs; false alarms: "different" to same pairs."""
    h, f = _rate(hits, different_trials, correction), _rate(false_alarms, same_trials, correction)
    k = -math.sqrt(2.0) * float(ndtri(f / 2.0))
    if h <= f:
        return Sensitivity(0.0, k, h, f)

    def excess(d):
        return float(ndtr((d - k) / math.sqrt(2.0)) + ndtr((-d - k) / math.sqrt(2.0))) - h

    return Sensitivity(float(brentq(excess, 0.0, 40.0, xtol=1e-12)), k, h, f)
