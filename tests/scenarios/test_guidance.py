"""Guidance laws of the positioning tasks (thesis §4.2; docs/scenarios.md "Guidance laws"): the
t_off tables of both vibration modes and patterns P1-P4 at the thesis's depths, the time-variant
switch, the 3-DoF FerroVibe directions, peg-in-hole and hot-wire cues."""

import pytest

from server.core.cues import PulseTrain, Tilt, Vibration
from scenarios.guidance import (PatternGuide, guidance_cues, guidance_tilt, hot_wire_cue, mode_t_off, p2_t_off,
                                peg_cue, pulse_cue)

DEPTHS = (0.0, 0.15, 0.3, 0.6, 0.9, 1.45, 2.0, 2.3)  # 2.3: beyond the zone (B = 2)
N = None
TABLES = {  # t_off in ms; 0.0 = continuous vibration; None = no vibration
    "continuous-at-target": (0.0, 75.0, 150.0, 300.0, 450.0, 725.0, 1000.0, N),
    "none-at-target": (N, 925.0, 850.0, 700.0, 550.0, 275.0, 0.0, N),
    "P1": (0.0, 75.0, 150.0, 300.0, 450.0, 725.0, 1000.0, N),
    "P2": (0.0, 25.0, 50.0, 75.0, 100.0, 300.0, 500.0, N),                        # form B (the study's)
    "P2-A": (0.0, 73.747, 140.277, 231.154, 260.615, 284.579, 476.715, N),       # 500·(sin 6x + 6x)/6, x = d/2
}


def in_zone(depth):
    return depth <= 2.0  # the object straight in front of the target: distance = depth


@pytest.mark.parametrize("mode", ["continuous-at-target", "none-at-target"])
def test_vibration_mode_tables(mode):
    got = [mode_t_off(mode, d, in_zone(d)) for d in DEPTHS]
    assert [None if v is None else round(v, 9) for v in got] == list(TABLES[mode])


@pytest.mark.parametrize("pattern, form, table", [("P1", "B", "P1"), ("P2", "B", "P2"), ("P2", "A", "P2-A"),
                                                  ("P3", "B", "P1"), ("P4", "B", "P2"), ("P4", "A", "P2-A")])
def test_pattern_tables_before_the_target_is_reached(pattern, form, table):
    guide = PatternGuide(pattern, form)
    got = [guide.t_off(d, in_zone(d), at_target=False) for d in DEPTHS]
    assert [None if v is None else round(v, 3) for v in got] == list(TABLES[table])
    assert not guide.reached


@pytest.mark.parametrize("pattern", ["P3", "P4"])
def test_time_variant_patterns_switch_after_the_first_reach(pattern):
    guide = PatternGuide(pattern)
    assert guide.t_off(0.6, True, at_target=False) == pytest.approx(300.0 if pattern == "P3" else 75.0)
    assert guide.t_off(0.0, True, at_target=True) == 0.0 and guide.reached
    # from now on: 1000·d within the 0.1 offset, nothing beyond it, whatever the pattern was
    after = [guide.t_off(d, in_zone(d), at_target=False) for d in (0.0, 0.05, 0.1, 0.15, 0.6, 2.0, 2.3)]
    assert after == [0.0, pytest.approx(50.0), pytest.approx(100.0), None, None, None, None]


@pytest.mark.parametrize("pattern", ["P1", "P2"])
def test_time_invariant_patterns_do_not_switch(pattern):
    guide = PatternGuide(pattern)
    guide.t_off(0.0, True, at_target=True)
    assert guide.t_off(0.6, True, at_target=False) == pytest.approx(300.0 if pattern == "P1" else 75.0)


def test_p2_form_b_is_continuous_at_its_knees():
    for knee in (0.3, 0.9):
        assert p2_t_off(knee - 1e-9) == pytest.approx(p2_t_off(knee + 1e-9), abs=1e-6)


def test_bad_mode_pattern_and_form_are_named():
    with pytest.raises(ValueError, match="vibration mode"):
        mode_t_off("sometimes", 0.1, True)
    with pytest.raises(ValueError, match="pattern must be one of P1, P2, P3, P4"):
        PatternGuide("P5")
    with pytest.raises(ValueError, match="P2 form"):
        PatternGuide("P2", "C")


def test_pulse_cue_turns_a_pause_into_a_cue():
    assert pulse_cue(None) is None
    assert pulse_cue(0.0) == Vibration(100.0)
    assert pulse_cue(150.0) == PulseTrain(50.0, 150.0, 100.0)


# -- 3-DoF guidance: octants, overshoot, vertical rate ------------------------------------------

T = (0.0, 0.0, 1.0)  # target; x toward the viewer, y right, z up


@pytest.mark.parametrize("obj, direction", [
    ((0.0, 0.5, 1.0), 90.0),     # target to the left → pushed from the right
    ((0.0, -0.5, 1.0), 270.0),   # target to the right
    ((0.5, 0.0, 1.0), 180.0),    # target in front (farther from the viewer) → hits the back
    ((-0.5, 0.0, 1.0), 0.0),     # overshoot: the object went past it → hits the front
    ((0.5, 0.5, 1.0), 135.0),    # left + front
    ((0.5, -0.5, 1.0), 225.0),   # right + front
    ((-0.5, 0.5, 1.0), 45.0),    # left + overshoot
    ((-0.5, -0.5, 1.0), 315.0),  # right + overshoot
    ((0.03, -0.04, 1.4), None),  # aligned in y and x (within 0.05): vertical cue only
])
def test_guidance_tilt_per_octant_and_overshoot(obj, direction):
    assert guidance_tilt(obj, T) == direction


def test_vertical_distance_is_pulse_rate_rising_toward_the_target_and_max_at_it():
    far, near = guidance_cues((0.0, 0.0, 0.0), T), guidance_cues((0.0, 0.0, 0.8), T)
    assert far == (PulseTrain(50.0, 500.0),) and near == (PulseTrain(50.0, 100.0),)
    assert guidance_cues((0.02, -0.03, 1.04), T) == (PulseTrain(50.0, 50.0),), "at target: only the maximum rate"
    assert guidance_cues((0.5, 0.5, 1.2), T) == (Tilt(135.0, 100.0), PulseTrain(50.0, 100.0))
    assert guidance_cues((0.0, 3.0, 1.0), T) == (), "outside the zone: nothing"


# -- peg-in-hole and hot wire -----------------------------------------------------------------

def test_peg_in_hole_rises_toward_the_hole_and_reverse_falls_to_nothing():
    assert peg_cue(2.5) is None
    assert peg_cue(2.0) == PulseTrain(50.0, 500.0, 30.0)
    assert peg_cue(1.0) == PulseTrain(50.0, 250.0, 65.0)
    assert peg_cue(0.0) == Vibration(100.0)
    assert peg_cue(2.0, reverse=True) == Vibration(100.0)
    assert peg_cue(0.04, reverse=True) is None
    weaker = peg_cue(0.5, reverse=True)
    assert weaker.intensity_pct < peg_cue(1.5, reverse=True).intensity_pct


def test_hot_wire_is_silent_within_the_threshold_and_beyond_the_maximum():
    assert hot_wire_cue(0.05, threshold=0.1, max_distance=0.5) is None
    assert hot_wire_cue(0.6, threshold=0.1, max_distance=0.5) is None
    low, high = hot_wire_cue(0.2, 0.1, 0.5), hot_wire_cue(0.4, 0.1, 0.5)
    assert low.intensity_pct < high.intensity_pct and low.t_off_ms > high.t_off_ms
    assert hot_wire_cue(0.5, 0.1, 0.5) == Vibration(100.0)
