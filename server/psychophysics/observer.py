"""The synthetic psychometric observer: answers drawn from p(x) = γ + (1 − γ − λ)·F (functions.py)
with a Generator the caller passes in, so a seed reproduces every answer.

- `PsychometricObserver`: one threshold, slope, guess and lapse.
- `ThresholdCurve`: the threshold as a function of a stimulus dimension. The default is a U over
  vibrotactile frequency in dB: lowest at `best` (250 Hz, the Pacinian channel's most sensitive
  frequency, Verrillo 1963, JASA 35:1962), rising `curvature` dB per squared octave away from it.
  The numbers are illustrative, not a fit to a data set.
- `WeberObserver`: discrimination of an increment Δ on a reference I, threshold Δ = k·I (Weber's
  law; k the Weber fraction).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from server.psychophysics.functions import FAMILIES


@dataclass(frozen=True)
class PsychometricObserver:
    threshold: float
    slope: float
    guess: float = 0.0
    lapse: float = 0.0
    family: str = "logistic"

    def probability(self, level):
        return FAMILIES[self.family].probability(level, self.threshold, self.slope, self.guess, self.lapse)

    def level_at(self, p: float) -> float:
        return float(FAMILIES[self.family].level_at(p, self.threshold, self.slope, self.guess, self.lapse))

    def answer(self, level, rng: np.random.Generator):
        """True (correct, or "yes") with probability p(level); arrays give arrays."""
        p = self.probability(level)
        return rng.random(np.shape(p)) < p


@dataclass(frozen=True)
class ThresholdCurve:
    """threshold(f) = minimum + curvature · log2(f / best)²  (dB)."""
    minimum: float = -20.0
    best: float = 250.0
    curvature: float = 6.0
    slope: float = 0.5
    guess: float = 0.5
    lapse: float = 0.02
    family: str = "gumbel"

    def threshold(self, frequency):
        return self.minimum + self.curvature * np.log2(np.asarray(frequency, dtype=float) / self.best) ** 2

    def observer_at(self, frequency: float) -> PsychometricObserver:
        return PsychometricObserver(float(self.threshold(frequency)), self.slope, self.guess, self.lapse, self.family)

    def probability(self, level, frequency):
        return FAMILIES[self.family].probability(level, self.threshold(frequency), self.slope, self.guess, self.lapse)


@dataclass(frozen=True)
class WeberObserver:
    """Discriminates I + Δ from I: a Weibull in Δ with threshold k·I."""
    weber_fraction: float
    slope: float = 3.0
    guess: float = 0.5
    lapse: float = 0.0

    def observer_at(self, reference: float) -> PsychometricObserver:
        if not reference > 0 or not math.isfinite(reference):
            raise ValueError(f"a Weber observer needs a reference > 0, got {reference!r}")
        return PsychometricObserver(self.weber_fraction * reference, self.slope, self.guess, self.lapse, "weibull")

    def answer(self, delta, reference: float, rng: np.random.Generator):
        return self.observer_at(reference).answer(delta, rng)
