"""The literature's psychophysical numbers, declared once with their sources: the report card draws
them as reference bands (server/report, docs/report-card.md) and the simulated battery's
`literature` population takes its values from them (server/synthetic/psychometric.py,
docs/battery.md "The simulated battery").

Detection thresholds are compared by shape only: a device's thresholds are in its own units (% of
its drive), the papers' in µm of skin displacement, so the card plots each device's thresholds in
dB re its own lowest one against the papers' band in dB re their minimum.
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
    measure: str            # the card's measure it is drawn on (a key of MEASURES in server/report/card.py)
    low: float
    high: float
    unit: str
    what: str
    sources: tuple[str, ...]  # keys of SOURCES

    @property
    def middle(self) -> float:
        return (self.low + self.high) / 2.0


@dataclass(frozen=True)
class DetectionEdge:
    """The detection band at one carrier: its low and high edge in dB re the curve's minimum."""
    frequency_hz: float
    low_db: float
    high_db: float

    @property
    def middle_db(self) -> float:
        return (self.low_db + self.high_db) / 2.0


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

# The Pacinian U: the detection threshold in dB re its minimum against frequency, lowest near
# 250 Hz. The band spans the fingertip to the large-contactor thenar eminence:
# - high edge, Verrillo (1963), 2.9 cm² contactor on the thenar: flat up to about 40 Hz, then
#   falling about 12 dB per octave to its minimum near 250–300 Hz (read literally some 20–28 dB
#   between 40 Hz and the minimum), rising above it;
# - low edge, Gescheider et al. (2002), the fingertip: shallower below the minimum (the
#   non-Pacinian channels set the threshold there, and the contactor is smaller), roughly
#   12–18 dB between 40 Hz and the minimum.
# Approximate readings of the published curves (their tables were not at hand), the band wide
# enough for contactor size and site and for a minimum anywhere in 250–300 Hz: a plausibility
# check of a curve's shape, not a norm.
DETECTION_BAND_DB = (
    DetectionEdge(40, 12.0, 28.0),
    DetectionEdge(80, 5.0, 16.0),
    DetectionEdge(160, 0.0, 6.0),
    DetectionEdge(250, -2.0, 2.0),
    DetectionEdge(320, -1.0, 4.0),
    DetectionEdge(400, 0.0, 8.0),
)
DETECTION_BEST_HZ = 250.0  # the Pacinian channel's best frequency, the curve's minimum (Verrillo 1963)
DETECTION_SOURCES = ("verrillo1963", "gescheider2002")

BANDS = MappingProxyType({b.measure: b for b in (
    Band("amplitude_jnd_db", 1.65, 2.98, "dB", "amplitude JND on the fingerpad, 25–250 Hz", ("israr2006",)),
    Band("frequency_weber", 0.13, 0.38, "", "frequency Weber fraction on the fingerpad, 25–250 Hz", ("israr2006",)),
    Band("stiffness_weber", 0.15, 0.22, "", "stiffness (compliance) Weber fraction",
         ("tan1995", "bergmanntiest2009")),
)})


def detection_band() -> dict:
    """The detection band as the card's stats.json and figure use it."""
    return {"frequency_hz": [e.frequency_hz for e in DETECTION_BAND_DB],
            "low_db": [e.low_db for e in DETECTION_BAND_DB], "high_db": [e.high_db for e in DETECTION_BAND_DB],
            "sources": list(DETECTION_SOURCES),
            "what": "vibrotactile detection threshold, dB re its minimum (U-shaped, lowest near 250 Hz): "
                    "fingertip (low edge) to large-contactor thenar (high edge)"}


def bands() -> dict:
    return {m: {"low": b.low, "high": b.high, "unit": b.unit, "what": b.what, "sources": list(b.sources)}
            for m, b in BANDS.items()}
