"""A procedure run against a synthetic observer: the answers drawn from the Generator passed in,
the procedure the production one (procedures.py). Used by the tests, `viestac bench
psychophysics` and, later, the simulated study."""

from __future__ import annotations

import numpy as np

from server.psychophysics.procedures import start


def run(spec, observer, rng: np.random.Generator, seed=0, max_trials: int = 100_000, after=None):
    """The finished procedure and its track: [(level, correct), ...]. `observer` has
    `probability(level)` (PsychometricObserver; a ThresholdCurve's `observer_at` for one dimension).
    `after(procedure, trials)`, when given, is called after every answer (to read the estimate as
    the procedure goes)."""
    procedure = start(spec, seed)
    track = []
    while not procedure.finished and len(track) < max_trials:
        level = procedure.level
        correct = bool(rng.random() < observer.probability(level))
        procedure.update(correct)
        track.append((level, correct))
        if after is not None:
            after(procedure, len(track))
    return procedure, track
