"""Device-independent cues: validation, wire form, and the simulated FerroVibe sink."""

import math

import pytest

from devices.cues import PulseTrain, Temperature, Texture, Tilt, Vibration, cue_to_wire, tilt_direction
from devices.simulated import SimulatedFerroVibe


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


def test_simulated_ferrovibe_sends_on_change_only():
    sink = SimulatedFerroVibe()
    assert sink.submit(0.000, (Tilt(90, 100),))[0]["command"] == "tilt"
    assert sink.submit(0.001, (Tilt(90, 100),)) == []
    assert sink.submit(0.002, (Tilt(91, 100),))[0]["direction_deg"] == 91
    assert sink.submit(0.003, ())[0]["command"] == "flat"
    assert sink.submit(0.004, (PulseTrain(),)) == []  # no tilt: stays flat
    assert [c["t"] for c in sink.commands] == [0.000, 0.002, 0.003]
