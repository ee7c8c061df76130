"""The simulation's data in one object (server/loop/sim_data.py): a snapshot taken between two
ticks and restored gives the same next ticks, bit for bit, for the same inputs; one snapshot
restores any number of times; the model (scenario object, scene) stays what it is."""

import math

import pytest

from scenarios.pick_place import BLOCK, BLOCK_SIDE, BLOCK_START, THUMB
from server.core.scenario import Trial
from server.loop.sim_data import TRACKER_BACK, TRACKER_LOST
from server.loop.simulation import Simulation
from scenarios import registry

MIDDLE = "right.middle.tip"  # a point that drives no tool: drawn only (`points`)


def fingerprint(sim: Simulation) -> str:
    """The data that is not in a tick's result, as text that tells every bit (a float's repr is exact)."""
    d = sim.data
    tools = [(t.name, t.tracked, t.held, t.driver, t.seq, t.ignored, t.lost, t.god.proxy, t.god.sticking, t.gate.on)
             for t in d.tools]
    return repr((d.tick, d.cues, d.tool_cues, d.refusals, d.trial, d.events, d.finished, d.points, d.point_source,
                 d.deadlines, d.lost_sources, d.moved, d.visibility, d.scales, d.stiffness, d.touch_overrides, d.bodies,
                 tools))


def run(sim: Simulation, first: int, ticks: int, inputs) -> list[str]:
    """Ticks `first` .. `first + ticks - 1`, the inputs scripted for each applied before it; every
    tick's result, then the data, as text."""
    out = []
    for k in range(first, first + ticks):
        for name, *args in inputs(k):
            getattr(sim, name)(*args)
        out.append(repr(sim.step()))
    out.append(fingerprint(sim))
    return out


# -- the scripted runs: tracker samples (a hand, ttls, a gap that loses the source), keys, trials --

def contact_angle_hand(k: int) -> list:
    """Two tools and a drawn point from one source with a 20 ms ttl, in and out of the dome; a
    silence at 300..359 loses the source; the experimenter hides the scale, taps, releases, shows it."""
    out = []
    if k % 8 == 0 and not 300 <= k < 360:
        x, z = 0.25 * math.sin(k / 90), 0.64 + 0.05 * math.sin(k / 40)
        out.append(("offer", "udp:a", k, (x, 0.0, z), None, {THUMB: (x, 0.12, z), MIDDLE: (x, 0.2, z + 0.1)}, 20.0))
    keys = {100: ("scale", "press", False), 120: ("tap_angle", "press", 30.0), 420: ("release", "press"),
            450: ("scale", "press", True)}
    if k in keys:
        out.append(("input", *keys[k]))
    return out


def pick_place_hand(k: int) -> list:
    """Index and thumb (one source) close on the block, grasp it and carry it towards the target."""
    x0, y0 = BLOCK_START
    touch = BLOCK_SIDE / 2 + 0.06
    gap = 0.1 - 0.13 * min(k, 100) / 100  # from 0.1 outside to 0.03 pressed in
    lift = 0.0015 * max(0, k - 160)  # then up and along x
    index, thumb = (x0 + lift, y0 + touch + gap, BLOCK_SIDE / 2 + lift), (x0 + lift, y0 - touch - gap, BLOCK_SIDE / 2 + lift)
    return [("offer", "hand", k + 1, index, None, {THUMB: thumb})]


def texture_touch(k: int) -> list:
    """The HIP on the plane (which moves under it while touched), lifted off at 250..299."""
    z = 0.2 if 250 <= k < 300 else 0.05
    out = [("set_hip", (0.1 * math.sin(k / 70), 0.1 * math.cos(k / 50), z))]
    if k == 0:
        out.append(("set_trial", Trial.parse(registry.create("texture").TRIAL_PARAMS, "main",
                                             {"period_us": 3000.0, "second_period_us": 5000.0})))
    if k == 350:
        out.append(("input", "next", "press"))
    return out


def stiffness_keys(k: int) -> list:
    """Across the three spheres; random levels for the middle one (the scenario's generator), the
    right one stepped, a recording that hides the left sphere."""
    out = [("set_hip", (0.0, 1.3 * math.sin(k / 60), 0.84 + 0.03 * math.sin(k / 25)))]
    if k == 0:
        out.append(("set_trial", Trial.parse(registry.create("stiffness").TRIAL_PARAMS, "main",
                                             {"mode": "production", "level": 4})))
    if k % 97 == 0:
        out.append(("input", "n", "press"))
    if k % 131 == 0:
        out.append(("input", "ArrowDown", "press"))
    if k in (200, 460):
        out.append(("input", "r", "press"))
    return out


CASES = {
    "contact-angle, two tools and a lost source": (lambda: Simulation(registry.create("contact-angle"), rig=(THUMB,)),
                                                    contact_angle_hand),
    "pick-place, two fingers carrying the block": (lambda: Simulation(registry.create("pick-place")), pick_place_hand),
    "texture, a moving plane": (lambda: Simulation(registry.create("texture")), texture_touch),
    "stiffness, random levels and hidden spheres": (lambda: Simulation(registry.create("stiffness")), stiffness_keys),
}


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("n", [60, 280])
def test_a_restored_snapshot_runs_the_same_ticks_bit_for_bit_again_and_again(case, n):
    make, inputs = CASES[case]
    sim = make()
    run(sim, 0, n, inputs)
    scenario, scene = sim.scenario, sim.scene
    snap = sim.snapshot()
    first = run(sim, n, 400, inputs)
    assert first[0] != first[-2], "the run after the snapshot changes something"
    for _ in range(2):
        sim.restore(snap)
        assert run(sim, n, 400, inputs) == first
    assert sim.scenario is scenario and sim.scene is scene, "restoring keeps the model"
    assert run(make(), 0, n + 400, inputs)[n:] == first, "and as a run that took no snapshot"


def test_the_scripted_runs_do_what_the_snapshot_must_carry():
    """The scripts above reach the state a snapshot must hold: a lost and returned source, a drawn
    point, a carried block, a moving plane, a hidden sphere."""
    sim, inputs = CASES["contact-angle, two tools and a lost source"][0](), contact_angle_hand
    events = []
    for k in range(0, 700):
        for name, *args in inputs(k):
            getattr(sim, name)(*args)
        sim.step()
        events += sim.data.events
        sim.data.events = []
        if k == 330:
            assert sim.data.deadlines == {} and sim.data.points == {}
    names = [e["name"] for e in events]
    assert TRACKER_LOST in names and TRACKER_BACK in names and MIDDLE in sim.data.points
    sim = CASES["pick-place, two fingers carrying the block"][0]()
    run(sim, 0, 400, pick_place_hand)
    assert sim.scenario.phase == "held" and sim.data.moved[BLOCK].pos[2] > BLOCK_SIDE / 2 + 0.1
    sim = CASES["texture, a moving plane"][0]()
    run(sim, 0, 200, texture_touch)
    assert "plane" in sim.data.moved
    sim = CASES["stiffness, random levels and hidden spheres"][0]()
    run(sim, 0, 300, stiffness_keys)
    assert sim.data.visibility.get("left") is False and "left" in sim.data.untouchable


def test_a_snapshot_shares_nothing_that_changes_with_the_running_simulation():
    sim = Simulation(registry.create("pick-place"))
    run(sim, 0, 200, pick_place_hand)
    snap = sim.snapshot()
    kept = fingerprint_of(snap.data)
    run(sim, 200, 200, pick_place_hand)
    assert fingerprint_of(snap.data) == kept
    assert snap.data.tools[0] is not sim.data.tools[0] and snap.data.tools[0].god is not sim.data.tools[0].god
    assert snap.data.tool_by_name[THUMB] is snap.data.tools[1], "the copy's lookup names the copy's tools"
    with pytest.raises(ValueError, match="another scene"):
        Simulation(registry.create("contact-angle")).restore(snap)


def fingerprint_of(data) -> str:
    holder = Simulation.__new__(Simulation)
    holder.data = data
    return fingerprint(holder)
