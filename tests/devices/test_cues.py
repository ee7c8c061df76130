"""Device-independent cues: validation and wire form (both directions)."""

import math

import pytest

from server.core.cues import (CUE_CLASSES, Friction, PulseTrain, Stop, Temperature, Texture, Tilt, Vibration, cue_from_wire,
                          cue_to_wire, tilt_direction)


def test_wire_form_names_kind_and_drops_absent_fields():
    assert cue_to_wire(Tilt(90.0, 100.0)) == {"kind": "tilt", "direction_deg": 90.0, "magnitude_pct": 100.0}
    assert cue_to_wire(PulseTrain(50, 200)) == {"kind": "pulse_train", "t_on_ms": 50, "t_off_ms": 200, "intensity_pct": 100.0}
    assert cue_to_wire(PulseTrain(50, 200, 80, 235.0))["carrier_hz"] == 235.0
    assert cue_to_wire(Texture(2000))["period_us"] == 2000


@pytest.mark.parametrize("make", [
    lambda: Tilt(361, 100), lambda: Tilt(10, 101), lambda: Tilt(math.nan, 1),
    lambda: PulseTrain(-1, 10), lambda: Vibration(150), lambda: Texture(50), lambda: Temperature(80),
])
def test_out_of_range_cues_are_refused(make):
    with pytest.raises(ValueError):
        make()


@pytest.mark.parametrize("angle, direction", [(-90, 90), (0, 0), (90, 270), (-0.0, 0), (360, 0), (-450, 90)])
def test_tilt_direction_normalises(angle, direction):
    d = tilt_direction(-angle)
    assert d == direction and math.copysign(1, d) == 1


@pytest.mark.parametrize("cue", [Tilt(90, 100), PulseTrain(50, 200, 80, 235.0), PulseTrain(), Vibration(40),
                                 Texture(2000, 0.25, 60), Temperature(34.5), Friction(0.8), Stop()])
def test_wire_form_round_trips(cue):
    assert cue_from_wire(cue_to_wire(cue)) == cue


def test_every_cue_class_has_a_distinct_kind():
    assert len({cls.kind for cls in CUE_CLASSES}) == len(CUE_CLASSES)


@pytest.mark.parametrize("body, message", [
    ({"kind": "smell"}, "unknown cue kind"), ({"direction_deg": 3}, "unknown cue kind"), ("tilt", "unknown cue kind"),
    ({"kind": "tilt", "angle": 3}, r"no field\(s\) angle"), ({"kind": "tilt", "direction_deg": 400}, "direction_deg"),
])
def test_bad_wire_cues_are_named(body, message):
    with pytest.raises(ValueError, match=message):
        cue_from_wire(body)
