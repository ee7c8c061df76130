"""Loop.tick on a virtual clock: the whole tick as data (fail-safe, cue hand-over and re-send,
scenario switches, the tracker rule, what the state record carries, trial ends)."""

from dataclasses import replace

import pytest

from scenarios.contact_angle import ContactAngle
from scenarios.stiffness import SPHERE_RADIUS, SPACING, StiffnessScenario
from server.core.tool import DEFAULT_PROXY_RADIUS, DRIVER_QUIET_S
from server.loop.tick import Loop
from server.loop.simulation import Simulation, home_position
from tests.experiment.test_recorder import recording  # noqa: F401 - the fixture
from server.ipc.records import Input, Log, RecordEvery, SwitchScenario, TrackerGone, TrackerSample, Trial
from tests.ipc import sent, state_map

MS = 1_000_000
TILT = [{"kind": "tilt", "direction_deg": 0.0, "magnitude_pct": 100.0}]
DOME_TOP = [0.0, 0.0, 0.6 + DEFAULT_PROXY_RADIUS - 0.003]  # 3 mm into the dilated dome: contact, tilt 0
FREE = [0.0, 0.0, 1.2]


class Flaky(ContactAngle):
    """The contact-angle task with a bug that can be switched on."""
    failing = False
    error = (RuntimeError, "scenario bug")  # what a failing step raises

    def step(self, ctx):
        if self.failing:
            raise self.error[0](self.error[1])
        return super().step(ctx)


class Finishing(ContactAngle):
    """Ends its trial at tick `at` with metrics through ScenarioOutput.finished, with (`with_event`)
    or without the trial_done event the scenarios emit beside it."""
    at = None
    with_event = False

    def step(self, ctx):
        out = super().step(ctx)
        if ctx.tick != self.at:
            return out
        events = out.events + (({"name": "trial_done", "completion_s": 1.5},) if self.with_event else ())
        return replace(out, finished={"completion_s": 1.5}, events=events)


def tracker(client, seq, pos, now=0):
    return TrackerSample(client, seq, float(seq), list(pos), None, now)


def run(core, ticks, records_at=None):
    """Run `ticks` ticks from the core's current tick; return the outputs' data per tick."""
    seen = []
    for _ in range(ticks):
        t = core.sim.data.tick
        out = core.tick((records_at or {}).get(t, ()), t * MS)
        seen.append({"tick": out.tick, "cues": out.cues, "records": [sent(r) for r in out.records],
                     "state": state_map(out.state), "failed": out.result is None, "error": out.error})
    return seen


def test_a_failing_step_turns_every_actuator_off_reports_once_and_the_next_good_tick_sends_again():
    scenario = Flaky()
    core = Loop(Simulation(scenario))
    first = run(core, 3, {0: [tracker(1, 0, DOME_TOP)]})
    assert [s["cues"] for s in first] == [TILT, None, None]
    scenario.failing = True
    failed = run(core, 3)
    assert [s["tick"] for s in failed] == [3, 4, 5] and core.sim.data.tick == 6, "the tick counter advances"
    assert all(s["failed"] and s["state"] is None for s in failed)
    assert [s["cues"] for s in failed] == [[], None, None], "every actuator off, once"
    kinds = [[r[0] if r[0] != "log" else r[1] for r in s["records"]] for s in failed]
    assert kinds == [["fail_safe", "error"], ["error"], ["error"]], "fail_safe once, every error reported"
    assert "scenario bug" in failed[0]["error"] and "tick failed (1)" in failed[0]["records"][1][2]
    scenario.failing = False
    recovered = run(core, 2)
    assert [s["cues"] for s in recovered] == [TILT, None], "the next good tick sends its cues again"
    assert recovered[0]["state"] is not None and recovered[0]["state"]["cues"] == TILT


def test_a_failing_scenario_reports_the_first_failures_then_every_thousandth():
    scenario = Flaky()
    core = Loop(Simulation(scenario))
    scenario.failing = True
    seen = run(core, 2000)
    reported = [s["tick"] for s in seen if any(r[0] == "log" for r in s["records"])]
    assert reported == list(range(10)) + [999, 1999]
    assert core.failures == 2000 and all(s["error"] for s in seen)


def test_cues_that_could_not_be_handed_over_go_again_next_tick():
    core = Loop(Simulation(ContactAngle()))
    out = core.tick([tracker(1, 0, DOME_TOP)], 0)
    assert out.cues == TILT
    assert core.tick((), MS).cues is None, "unchanged and delivered: nothing to send"
    core.resend_device_cues()  # the driver's send failed (the feed is behind)
    assert core.tick((), 2 * MS).cues == TILT, "the same cues again, though nothing changed"
    assert core.tick((), 3 * MS).cues is None


def test_a_switch_announces_scene_and_scenario_and_turns_the_old_cue_off():
    core = Loop(Simulation(ContactAngle()), state_hz=1000)
    run(core, 2, {0: [tracker(1, 0, DOME_TOP)]})
    out = core.tick([SwitchScenario("stiffness", {}, 3)], 2 * MS)
    assert [r[0] for r in map(sent, out.records)] == ["scene", "scenario"]
    assert sent(out.records[0])[2] == core.sim.scene.hash and sent(out.records[1])[1]["id"] == "stiffness-v1"
    assert out.tick == 2 and out.cues == [], "the devices still showed the tilt: off goes out"
    assert state_map(out.state)["scene"] == sent(out.records[0])[2], "the state names the scene it was simulated in"


def test_a_bad_record_is_reported_and_the_tick_goes_on():
    core = Loop(Simulation(ContactAngle()))
    out = core.tick([SwitchScenario("no-such-scenario", {}, 0), tracker(1, 0, DOME_TOP)], 0)
    (level, text), = [r[1:] for r in map(sent, out.records)]
    assert level == "error" and "record scenario failed" in text and "no-such-scenario" in text
    assert out.result is not None and out.cues == TILT, "the records after it still apply"


# -- the tracker rule ------------------------------------------------------------------------------

def test_one_source_drives_the_hip_others_are_ignored_and_counted():
    core = Loop(Simulation(ContactAngle()))
    out = core.tick([tracker(1, 0, FREE), tracker("udp:10.0.0.2:5000", 0, DOME_TOP)], 0)
    assert out.result.hip == tuple(FREE), "the first source drives; the second is ignored"
    assert state_map(out.state)["driver"] == [1, 0]
    assert [row[0] for row in state_map(out.state)["trackers"]] == [1], "only applied samples are rows"
    assert out.records == [Log("warning", "tracker samples from udp:10.0.0.2:5000 ignored: 1 drives the HIP "
                                              "(1 ignored so far)")]
    seen = run(core, 40, {t: [tracker("udp:10.0.0.2:5000", t, DOME_TOP)] for t in range(1, 40)})
    assert all(s["cues"] is None for s in seen) and core.sim.tool.ignored == {"udp:10.0.0.2:5000": 40}
    assert all(s["records"] == [] for s in seen), "one log line, not one per sample"
    out = core.tick([tracker(1, 1, DOME_TOP)], 41 * MS)
    assert out.cues == TILT and core.sim.tool.seq == 1


def test_a_quiet_driver_loses_the_hip_after_driver_quiet_s():
    core = Loop(Simulation(ContactAngle()))
    core.tick([tracker(1, 0, FREE)], 0)
    quiet = round(DRIVER_QUIET_S * 1000)
    run(core, quiet - 2)
    assert core.sim.data.tick == quiet - 1
    out = core.tick([tracker(2, 0, DOME_TOP)], (quiet - 1) * MS)
    assert out.result.hip == tuple(FREE), "silent for less than DRIVER_QUIET_S: still the driver's"
    out = core.tick([tracker(2, 1, DOME_TOP)], quiet * MS)
    assert out.result.hip == tuple(DOME_TOP) and out.state is not None and state_map(out.state)["driver"] == [2, 1]
    out = core.tick([tracker(1, 1, FREE)], (quiet + 1) * MS)
    assert out.result.hip == tuple(DOME_TOP), "the old driver is now the other source"


def test_when_the_driver_leaves_the_hip_goes_home_and_the_contact_cue_stops():
    core = Loop(Simulation(ContactAngle()), state_hz=1000)
    home = home_position(core.sim.scene)
    run(core, 5, {0: [tracker(7, 0, DOME_TOP)]})
    out = core.tick([TrackerGone(8)], 5 * MS)
    assert out.result.hip == tuple(DOME_TOP) and state_map(out.state)["driver"] == [7, 0], "someone else left: nothing changes"
    seen = run(core, 60, {6: [TrackerGone(7)]})
    assert seen[0]["state"]["hip"] == pytest.approx(list(home)) and seen[0]["state"]["driver"] is None
    assert [s["cues"] for s in seen if s["cues"] is not None] == [[]], "free space: the tilt stops (after the gate)"
    out = core.tick([tracker(9, 0, DOME_TOP)], 66 * MS)
    assert state_map(out.state)["driver"] == [9, 0] and out.cues == TILT, "the next source drives at once"


def test_the_driver_stays_across_a_scenario_switch():
    core = Loop(Simulation(ContactAngle()), state_hz=1000)
    core.tick([tracker(1, 4, FREE)], 0)
    out = core.tick([SwitchScenario("stiffness", {}, 0), tracker(2, 0, DOME_TOP)], MS)
    assert state_map(out.state)["driver"] == [1, 4] and core.sim.tool.ignored == {2: 1}


# -- what the state record carries ------------------------------------------------------------------

def test_the_state_record_holds_the_wire_fields_in_their_order_then_the_loops_own():
    core = Loop(Simulation(ContactAngle()))
    state = state_map(core.tick([tracker(3, 0, DOME_TOP)], 0).state)
    assert list(state) == ["frame", "tick", "t", "scene", "hip", "proxy", "force", "contact", "contacts", "objects",
                           "cues", "hud", "values", "visible", "events", "scales", "stiffness", "haptic", "driver",
                           "tools", "points", "tracking",  # v1.4 wire fields, in their declared order
                           "samples", "trackers", "trajectory", "finished"]
    assert (state["scene"], state["driver"], state["stiffness"], state["haptic"], state["finished"]) == \
        (core.sim.scene.hash, [3, 0], {}, {}, [])


def test_the_state_record_carries_stiffness_so_a_client_computes_the_force():
    """The god-object's spring (server/core/haptics/god_object.py, GodObject.step): in contact,
    force = k · (proxy − hip) with k the stiffness_n_per_m of the touched body, or the mean over
    the touched bodies when there are several (touched: the proxy lies on the body's surface
    dilated by the proxy radius; of those, only the ones the HIP pushes into, if any); free
    (nothing between proxy and HIP), force = 0. With the record's `stiffness` (overrides of the
    scene's material stiffness) a client computes the force the loop reports, to the record's
    rounding, also in the tick a key changes k (the record has the set that tick rendered with)."""
    core = Loop(Simulation(StiffnessScenario()), state_hz=1000)  # a record every tick
    scene_k = {o.id: o.material.stiffness_n_per_m for o in core.sim.scene.objects}
    top = [0.0, SPACING, 2 * SPHERE_RADIUS + DEFAULT_PROXY_RADIUS - 0.004]  # 4 mm into the right sphere
    keys = {50: [Input(1, "ArrowDown", "down")], 51: [Input(1, "ArrowDown", "down")],
            90: [Input(1, "ArrowUp", "down")]}
    states = [s["state"] for s in run(core, 120, {0: [tracker(1, 0, top)], **keys})]
    assert states[0]["stiffness"] == {} and states[0]["scene"] == core.sim.scene.hash
    assert states[60]["stiffness"] == {"right": 80.0} and states[100]["stiffness"] == {"right": 90.0}
    touching = [s for s in states if [c[0] for c in s["contacts"]] == ["right"]]
    assert len(touching) >= 115
    for s in touching:
        k = s["stiffness"].get("right", scene_k["right"])
        expected = [k * (p - h) for p, h in zip(s["proxy"], s["hip"])]
        assert s["force"] == pytest.approx(expected, abs=1e-6), s["tick"]
    assert {round(s["force"][2], 2) for s in touching} == {0.4, 0.32, 0.36}, "100, 80 and 90 N/m × 4 mm"


def test_the_state_record_carries_the_touchability_overrides():
    core = Loop(Simulation(StiffnessScenario()))
    out = core.tick([Input(1, "r", "press")], 0)  # recording hides the left sphere and makes it untouchable
    assert state_map(out.state)["haptic"] == {}, "the tick that asks renders with the old set"
    states = [s["state"] for s in run(core, 40) if s["state"] is not None]
    assert states[0]["haptic"] == {"left": False} and states[0]["visible"]["left"] is False
    run(core, 1, {core.sim.data.tick: [Input(1, "r", "press")]})
    assert [s["state"]["haptic"] for s in run(core, 40) if s["state"] is not None][-1] == {}


@pytest.mark.parametrize("with_event", [False, True])
def test_a_trial_end_rides_with_the_next_state_record_as_finished_and_as_an_event(with_event):
    scenario = Finishing()
    scenario.at, scenario.with_event = 5, with_event
    core = Loop(Simulation(scenario))
    states = [s["state"] for s in run(core, 40) if s["state"] is not None]
    assert [s["tick"] for s in states[:2]] == [0, 17], "tick 5 publishes nothing"
    assert states[1]["finished"] == [{"tick": 5, "metrics": {"completion_s": 1.5}}]
    done = [e for s in states for e in s["events"] if e["name"] == "trial_done"]
    assert done == [{"tick": 5, "t": 0.005, "name": "trial_done", "completion_s": 1.5}], "one event, as before"
    assert all(s["finished"] == [] for s in states if s is not states[1]), "each trial end is published once"


def test_the_recorder_takes_a_trials_metrics_from_the_loops_finished_entries(recording):  # noqa: F811
    _, recorder, _ = recording
    scenario = Finishing()
    scenario.at = 30
    core = Loop(Simulation(scenario))
    out = core.tick([Trial({"phase": "main", "params": {"angle_deg": 10.0}, "index": 0})], 0)
    for _ in range(60):
        for record in out.records:
            recorder.on_record(record)
        if out.state is not None:
            recorder.on_record(out.state)
        out = core.tick((), core.sim.data.tick * MS)
    assert recorder.end().metrics == {"completion_s": 1.5}


class Carrying(ContactAngle):
    """Makes the hemisphere untouchable, moves it along x for a few ticks (a carried object), then
    makes it touchable again or changes its stiffness, as `script` says, tick by tick."""
    script: dict = {}

    def step(self, ctx):
        out = super().step(ctx)
        what = self.script.get(ctx.tick)
        if what is None:
            return out
        kind, value = what
        if kind == "haptic":
            return replace(out, touchable={"hemisphere": value})
        if kind == "stiffness":
            return replace(out, stiffness={"hemisphere": value})
        return replace(out, poses={"hemisphere": value})


def test_a_body_moved_while_untouchable_is_where_it_was_last_moved_when_it_counts_again():
    from server.core.haptics.primitives import Pose
    sim = Simulation(Carrying(), tick_hz=1000)
    sim.scenario.script = {0: ("haptic", False), **{t: ("pose", Pose((0.1 * t, 0.0, 0.0))) for t in range(1, 6)},
                           6: ("stiffness", 123.0), 7: ("haptic", True)}
    for _ in range(7):
        sim.step()
        assert "hemisphere" not in {b.id for b in sim.data.bodies}, "untouchable while carried"
    sim.step()
    body = {b.id: b for b in sim.data.bodies}["hemisphere"]
    assert body.pose.pos == (0.5, 0.0, 0.0), "the last pose it was given, not the one it was made untouchable at"
    assert body.stiffness_n_per_m == 123.0, "a change made while untouchable is kept"
    assert sim.data.moved["hemisphere"].pos == (0.5, 0.0, 0.0)


def test_a_run_nobody_draws_records_the_same_and_leaves_the_picture_out():
    from scenarios.positioning import Positioning
    drawn, undrawn = (Loop(Simulation(Positioning(), tick_hz=1000), drawn=flag) for flag in (True, False))
    for core in (drawn, undrawn):
        core.apply(RecordEvery(5), 0)
        for t in range(40):
            core.sim.set_hip((0.0, 0.1 * t / 40, 1.0))
            out = core.tick((), t * MS)
            if out.state is not None:
                core.last = state_map(out.state)
    full, slim = drawn.last, undrawn.last
    assert set(slim) == {"frame", "tick", "t", "scene", "cues", "hud", "events", "samples", "trackers",
                         "trajectory", "finished"}
    assert {k: full[k] for k in slim} == slim, "what a recorder reads is the same"
    assert full["values"] and "hip" in full
    assert undrawn.sim.drawn is False and drawn.sim.drawn is True
    undrawn.apply(SwitchScenario("contact-angle", {}, 0), 0)
    assert undrawn.sim.drawn is False, "a switched-in simulation is not drawn either"
