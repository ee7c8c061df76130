"""Literature reference bands of the report card, declared once with their sources
(docs/report-card.md explains every band and number). The card draws them on its figures and
prints each source under the figure that shows it.

Detection thresholds are compared by shape only: a device's thresholds are in its own units (% of
its drive), the papers' in µm of skin displacement, so the card plots each device's thresholds in
dB re its own lowest one against the papers' curve in dB re its minimum.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType


@dataclass(frozen=True)
class Source:
    key: str
    citation: str


@dataclass(frozen=True)
class Band:
    measure: str            # the card's measure it is drawn on (a key of MEASURES in card.py)
    low: float
    high: float
    unit: str
    what: str
    sources: tuple[str, ...]  # keys of SOURCES


SOURCES = MappingProxyType({s.key: s for s in (
    Source("verrillo1963", "Verrillo, R. T. (1963). Effect of contactor area on the vibrotactile threshold. "
                           "Journal of the Acoustical Society of America, 35(12), 1962–1966."),
    Source("gescheider2002", "Gescheider, G. A., Bolanowski, S. J., Pope, J. V., & Verrillo, R. T. (2002). A "
                             "four-channel analysis of the tactile sensitivity of the fingertip: frequency "
                             "selectivity, spatial summation, and temporal summation. Somatosensory & Motor "
                             "Research, 19(2), 114–124."),
    Source("israr2006", "Israr, A., Tan, H. Z., & Reed, C. M. (2006). Frequency and amplitude discrimination "
                        "along the kinesthetic-cutaneous continuum in the presence of masking stimuli. Journal "
                        "of the Acoustical Society of America, 120(5), 2789–2800."),
    Source("tan1995", "Tan, H. Z., Durlach, N. I., Beauregard, G. L., & Srinivasan, M. A. (1995). Manual "
                      "discrimination of compliance using active pinch grasp: the roles of force and work cues. "
                      "Perception & Psychophysics, 57(4), 495–510."),
    Source("bergmanntiest2009", "Bergmann Tiest, W. M., & Kappers, A. M. L. (2009). Cues for haptic perception "
                                "of compliance. IEEE Transactions on Haptics, 2(4), 189–199."),
)})

# The Pacinian U: detection threshold in dB re its minimum against frequency (Hz), a band of
# ±DETECTION_HALF_WIDTH_DB around it. The shape of the large-contactor curve of Verrillo (1963)
# and of the fingertip's P channel (Gescheider et al. 2002): lowest near 250 Hz, some 15 dB higher
# at 40 Hz, rising again above 300 Hz. Values read off the published figures, good to a few dB
# (hence the band's width): a plausibility check of a curve's shape, not a norm.
DETECTION_SHAPE_DB = ((40, 16.0), (80, 8.0), (160, 2.0), (250, 0.0), (320, 1.5), (400, 4.0))
DETECTION_HALF_WIDTH_DB = 4.0
DETECTION_SOURCES = ("verrillo1963", "gescheider2002")

BANDS = MappingProxyType({b.measure: b for b in (
    Band("amplitude_jnd_db", 1.65, 2.98, "dB", "amplitude JND on the fingerpad, 25–250 Hz", ("israr2006",)),
    Band("frequency_weber", 0.13, 0.38, "", "frequency Weber fraction on the fingerpad, 25–250 Hz", ("israr2006",)),
    Band("stiffness_weber", 0.15, 0.22, "", "stiffness (compliance) Weber fraction",
         ("tan1995", "bergmanntiest2009")),
)})


def detection_band() -> dict:
    """The detection-threshold shape as the card's stats.json and figure use it."""
    return {"frequency_hz": [f for f, _ in DETECTION_SHAPE_DB], "db_re_min": [d for _, d in DETECTION_SHAPE_DB],
            "half_width_db": DETECTION_HALF_WIDTH_DB, "sources": list(DETECTION_SOURCES),
            "what": "vibrotactile detection threshold, dB re its minimum (U-shaped, lowest near 250 Hz)"}


def bands() -> dict:
    return {m: {"low": b.low, "high": b.high, "unit": b.unit, "what": b.what, "sources": list(b.sources)}
            for m, b in BANDS.items()}
