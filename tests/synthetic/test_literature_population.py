"""The simulated battery's `literature` population (server/synthetic/psychometric.py LITERATURE)
agrees with the literature bands the report card draws (server/psychophysics/literature.py): its
detection curve lies inside the detection band at every band frequency, its amplitude JND and its
frequency and stiffness Weber fractions inside their bands. Both read the one declaration, so a
change of the band moves the population with it."""

from __future__ import annotations

import math

import pytest

from server.psychophysics import literature
from server.synthetic.psychometric import LITERATURE, LITERATURE_RANGES, PRESETS, literature_curvature_db


@pytest.mark.parametrize("edge", literature.DETECTION_BAND_DB, ids=lambda e: f"{e.frequency_hz:g}Hz")
def test_the_detection_curve_lies_inside_the_band(edge):
    curve = LITERATURE.curve()
    lowest = float(curve.threshold(literature.DETECTION_BEST_HZ))
    re_minimum = float(curve.threshold(edge.frequency_hz)) - lowest
    assert edge.low_db <= re_minimum <= edge.high_db, (edge, re_minimum)


def test_the_curve_is_the_least_squares_fit_of_the_bands_midline():
    assert PRESETS["literature"] is LITERATURE
    assert LITERATURE.best_hz == literature.DETECTION_BEST_HZ
    assert LITERATURE.curvature_db == literature_curvature_db()
    # the fit's normal equation: the residuals are orthogonal to log2(f / best)²
    x2 = [math.log2(e.frequency_hz / LITERATURE.best_hz) ** 2 for e in literature.DETECTION_BAND_DB]
    residuals = [e.middle_db - LITERATURE.curvature_db * x for e, x in zip(literature.DETECTION_BAND_DB, x2)]
    assert sum(r * x for r, x in zip(residuals, x2)) == pytest.approx(0.0, abs=1e-9)


def test_the_discrimination_fractions_lie_inside_their_bands():
    jnd_db = 20 * math.log10(1 + LITERATURE.weber["intensity_pct"])
    amplitude = literature.BANDS["amplitude_jnd_db"]
    assert amplitude.low <= jnd_db <= amplitude.high
    assert jnd_db == pytest.approx(amplitude.middle)
    for parameter, measure in (("carrier_hz", "frequency_weber"), ("relative", "stiffness_weber")):
        band = literature.BANDS[measure]
        assert band.low <= LITERATURE.weber[parameter] <= band.high, parameter
        assert LITERATURE_RANGES[parameter] == (band.low, band.high)
    low, high = LITERATURE_RANGES["intensity_pct"]
    assert 20 * math.log10(1 + low) == pytest.approx(amplitude.low)
    assert 20 * math.log10(1 + high) == pytest.approx(amplitude.high)
