"""Contact debouncer for vibration-only devices: hysteresis band + minimum dwell times.

Theory of operation
-------------------
A vibrotactile wearable has no force path back into the tracked hand, so what goes wrong at a
surface is not instability but chattering: tracker noise makes the HIP straddle the surface and a
raw "in contact" flag toggles at up to the tracker rate (~120 Hz for a Leap Motion), which the
wearer feels as a blur of pulses (docs/reference.md "Stability"). The gate turns the raw flag into a
clean on/off signal with two mechanisms:

* Hysteresis band: switch on when the god-object reports contact, switch off only once the HIP
  is at least ``band`` outside the (dilated) surface, ``separation >= band``. The default
  2 mm is ~4 sigma of the Leap's static jitter (sigma < 0.5 mm, Guna et al. 2014, Sensors
  14(2):3702), so a HIP resting on a surface essentially never leaves the band by noise alone.
* Minimum dwell: no transition sooner than ``min_on_s`` after switching on or ``min_off_s`` after
  switching off. ~30 ms is the minimum duration at which a stimulus is felt as a vibration rather
  than a pulse (40-590 Hz; Remache-Vinueza et al. 2025, Sci. Rep. 15:5057).

Time comes in as an argument (``t_s``, seconds, any monotonic origin): the gate never reads a
clock, so it is deterministic and testable.
"""

from __future__ import annotations

from ..numbers import is_finite_number
from .compiled import chaptics

BAND = 0.002        # the default hysteresis band, scene units (above: ~4 sigma of a Leap's jitter)
MIN_DWELL_S = 0.030  # the default minimum on and off time (above: felt as a vibration, not a pulse)


class ReferenceContactGate:
    """The readable reference; ``ContactGate`` (below) is the compiled twin when it is built."""

    def __init__(self, band: float = BAND, min_on_s: float = MIN_DWELL_S,
                 min_off_s: float = MIN_DWELL_S) -> None:
        for name, v in (("band", band), ("min_on_s", min_on_s), ("min_off_s", min_off_s)):
            if not is_finite_number(v) or v < 0:
                raise ValueError(f"{name} must be a finite number >= 0, got {v!r}")
        self.band = float(band)
        self.min_on_s = float(min_on_s)
        self.min_off_s = float(min_off_s)
        self._on = False
        self._t_change: float | None = None  # time of the last transition (None: never)

    @property
    def on(self) -> bool:
        return self._on

    def reset(self) -> None:
        """Off, with no dwell pending (the next contact switches on at once)."""
        self._on = False
        self._t_change = None

    def update(self, t_s: float, touching: bool, separation: float) -> bool:
        """Feed one sample: ``touching`` = the god-object has a contact this tick, ``separation``
        = ProxyStep.separation (HIP distance outside the nearest dilated body, < 0 inside).
        Returns the gated state."""
        since = _elapsed(self._t_change, t_s)
        if self._on:
            if separation >= self.band and since >= self.min_on_s:
                self._on = False
                self._t_change = t_s
        elif touching and since >= self.min_off_s:
            self._on = True
            self._t_change = t_s
        return self._on


def _elapsed(t_change: float | None, t_s: float) -> float:
    """Seconds since the last transition; +inf before the first one."""
    return float("inf") if t_change is None else t_s - t_change


if chaptics is not None:
    class ContactGate(chaptics.Gate):  # state, ``on``, ``reset`` and ``update`` in _chaptics.c
        __doc__ = ReferenceContactGate.__doc__
        __init__ = ReferenceContactGate.__init__
        _STATE = ("band", "min_on_s", "min_off_s", "_on", "_t_change")

        def __getstate__(self) -> dict:  # the state is in C, out of reach of copy and pickle
            return {name: getattr(self, name) for name in self._STATE}

        def __setstate__(self, state: dict) -> None:
            for name in self._STATE:
                setattr(self, name, state[name])
else:
    ContactGate = ReferenceContactGate  # type: ignore[misc]
