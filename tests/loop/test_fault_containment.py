"""A tick that fails is contained: counted, reported (`fault`, then `recovered`), and the next good
sample recovers the god-object. Issue 18, defect 1: trackers at [0,1e154,0.5], [0,1.35e154,0.5],
then [0.1,0.1,0.5] wedged the god-object with OverflowError in every tick."""

from scenarios.contact_angle import ContactAngle
from server.core.workspace import WORKSPACE_HALF_EXTENT_M
from server.loop import tick as core_module
from server.loop.tick import Loop
from server.loop.simulation import Simulation
from tests.loop.test_tick import Flaky
from server.ipc.records import TrackerSample
from tests.ipc import sent, state_map

MS = 1_000_000
DOME_TOP = (0.0, 0.0, 0.66)  # the dome is 0.6 high, the proxy 0.06 in radius


def tracker(seq, pos, client=1):
    return TrackerSample(client, seq, float(seq), list(pos), None, seq * MS)


def run(core, records_by_tick, ticks):
    outs = []
    for _ in range(ticks):
        t = core.sim.data.tick
        out = core.tick(records_by_tick.get(t, ()), t * MS)
        outs.append({"tick": out.tick, "error": out.error, "faults": [sent(f) for f in out.faults], "state": state_map(out.state),
                     "proxy": out.result.proxy if out.result else None})
    return outs


def test_huge_tracker_positions_do_not_wedge_the_loop_and_a_sane_sample_is_rendered():
    core = Loop(Simulation(ContactAngle()))
    outs = run(core, {0: [tracker(0, (0, 1e154, 0.5))], 1: [tracker(1, (0, 1.35e154, 0.5))],
                      2: [tracker(2, (0.1, 0.1, 0.5))]}, 40)
    assert all(o["error"] is None for o in outs), outs[-1]["error"]
    assert core.failures == 0
    # Inside the workspace, and the sane sample inside the dome puts the proxy on its surface.
    assert all(abs(v) <= WORKSPACE_HALF_EXTENT_M for o in outs for v in o["proxy"])
    x, y, z = outs[-1]["proxy"]
    assert abs((x * x + y * y + z * z) ** 0.5 - 0.66) < 1e-9


def test_a_tool_clamps_what_it_is_offered_and_placed_at():
    sim = Simulation(ContactAngle())
    tool = sim.data.tools[0]
    assert tool.offer(1, 0, (0.0, 1e308, -1e308), 0.0)
    assert tool.tracked == (0.0, WORKSPACE_HALF_EXTENT_M, -WORKSPACE_HALF_EXTENT_M)
    sim.set_hip((float("nan"), float("inf"), 0.3))
    assert tool.tracked == (0.0, WORKSPACE_HALF_EXTENT_M, 0.3)


class Exploding(Flaky):
    """Fails while `failing` is set, as the god-object did (any exception in a step)."""
    error = (OverflowError, "(34, 'Numerical result out of range')")


def test_a_failing_tick_is_counted_reported_and_recovered_from(monkeypatch):
    monkeypatch.setattr(core_module, "FAULT_REPORT_EVERY", 5)
    scenario = Exploding()
    core = Loop(Simulation(scenario))
    run(core, {0: [tracker(0, DOME_TOP)]}, 3)
    tool = core.sim.data.tools[0]
    assert tool.god.proxy is not None
    scenario.failing = True
    failed = run(core, {}, 12)
    assert core.failures == 12 and all(o["error"] for o in failed)
    assert tool.god.proxy is None, "a failure forgets the god-object's state"
    faults = [(o["tick"], o["faults"]) for o in failed if o["faults"]]
    # the first failure, then at most once every FAULT_REPORT_EVERY ticks while failures continue
    assert [t for t, _ in faults] == [3, 8, 13]
    first = faults[0][1][0]
    assert first[0] == "fault" and first[1]["failures"] == 1 and first[1]["tick"] == 3
    assert first[1]["error"].startswith("OverflowError: ")
    assert faults[1][1][0][1]["failures"] == 6
    scenario.failing = False
    back = run(core, {}, 40)
    assert back[0]["faults"] == [["recovered", {"tick": 15, "failures": 12}]]
    assert all(not o["faults"] for o in back[1:]), "recovered once"
    states = [o["state"] for o in back if o["state"] is not None]
    assert states and all(s["failures"] == 12 for s in states), "the state record counts the failures"
    # a new streak is reported from its first failure again
    scenario.failing = True
    again = run(core, {}, 1)
    assert again[0]["faults"][0][0] == "fault" and again[0]["faults"][0][1]["failures"] == 13


def test_no_failure_no_failures_key_in_the_state_record():
    core = Loop(Simulation(ContactAngle()))
    state = next(o["state"] for o in run(core, {}, 20) if o["state"] is not None)
    assert "failures" not in state


def test_a_proxy_left_far_away_by_a_failure_is_not_reused(monkeypatch):
    """Even a god-object that got somewhere absurd is forgotten by the failure it causes."""
    core = Loop(Simulation(ContactAngle()))
    run(core, {0: [tracker(0, DOME_TOP)]}, 2)
    tool = core.sim.data.tools[0]
    tool.god.reset((0.0, 1.35e154, 0.5))  # what a driver without the clamp could leave behind
    original = tool.god.step

    def step_that_overflows_far_away(bodies, hip):
        if tool.god.proxy is not None and abs(tool.god.proxy[1]) > 1e100:
            raise OverflowError("far away")
        return original(bodies, hip)
    monkeypatch.setattr(tool.god, "step", step_that_overflows_far_away)
    outs = run(core, {2: [tracker(1, (0.1, 0.1, 0.5))]}, 5)
    assert outs[0]["error"] is not None and all(o["error"] is None for o in outs[1:])
    x, y, z = outs[-1]["proxy"]
    assert abs((x * x + y * y + z * z) ** 0.5 - 0.66) < 1e-9


