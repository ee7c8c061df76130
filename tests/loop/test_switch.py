"""Scenario switches off the tick (server/loop/tick.py): with build_off_tick, tick() never builds a
scenario; the driver builds it and installs it between ticks; records during the build go to the
running scenario, trials wait for the new one, the latest switch wins."""

from scenarios.contact_angle import ContactAngle
from server.loop.tick import Loop
from server.loop.simulation import Simulation
from server.ipc.records import Input, SwitchScenario, Trial
from tests.ipc import sent, state_map

MS = 1_000_000
TRIAL = {"phase": "main", "params": {"mode": "production", "level": 7, "start_level": 2}, "index": 5}


class CountingBuilds:
    def __init__(self):
        self.built = []

    def __call__(self, scenario, seed):
        self.built.append(scenario.id)
        return Simulation(scenario, seed=seed)


def off_tick_core():
    make = CountingBuilds()
    return Loop(Simulation(ContactAngle()), state_hz=1000, make_sim=make, build_off_tick=True), make


def test_tick_never_builds_a_switch_it_only_records_it():
    core, make = off_tick_core()
    core.tick((), 0)
    out = core.tick([SwitchScenario("stiffness", {"middle_level": 3}, 4), Input(1, "space", "press")], MS)
    assert make.built == [], "no scenario was built inside the tick"
    assert core.pending_switch is not None and core.pending_switch.name == "stiffness"
    assert core.sim.scenario.id == "contact-angle-v1" and state_map(out.state)["scene"] == core.sim.scene.hash
    assert not [r for r in list(map(sent, out.records)) if r[0] in ("scene", "scenario")], "nothing announced before it is installed"
    assert [e["key"] for e in state_map(out.state)["events"] if e["name"] == "input"] == ["space"], \
        "a key during the build goes to the running scenario"
    for t in range(2, 5):
        assert state_map(core.tick((), t * MS).state)["scene"] == state_map(out.state)["scene"]
    assert make.built == []

    switch = core.pending_switch
    sim = core.build(switch)  # the driver, off the tick
    assert make.built == ["stiffness-v1"] and core.sim.scenario.id == "contact-angle-v1", "building installs nothing"
    assert core.install(switch, sim) and core.pending_switch is None
    out = core.tick((), 5 * MS)
    assert [r[0] for r in list(map(sent, out.records))] == ["scene", "scenario"], "announced with the first tick after the install"
    assert list(map(sent, out.records))[1][1]["id"] == "stiffness-v1" and list(map(sent, out.records))[1][1]["tick"] == 5
    assert state_map(out.state)["scene"] == list(map(sent, out.records))[0][2] and out.tick == 5, "the tick counter goes on"


def test_a_trial_sent_after_a_switch_waits_for_the_new_scenario():
    core, _ = off_tick_core()
    core.tick([SwitchScenario("stiffness", {}, 0), Trial(TRIAL)], 0)
    assert core.sim.data.trial is None, "the trial is for the scenario being built, not the running one"
    switch = core.pending_switch
    core.install(switch, core.build(switch))
    assert core.sim.scenario.id == "stiffness-v1" and core.sim.data.trial is not None and core.sim.data.trial.index == 5
    scenarios = [r[1] for r in list(map(sent, core.outbox)) if r[0] == "scenario"]
    assert scenarios[-1]["trial"]["index"] == 5, "the trial is announced right after the new scenario"


def test_a_second_switch_during_the_build_wins_and_the_first_is_discarded():
    core, make = off_tick_core()
    core.tick([SwitchScenario("stiffness", {}, 0), Trial(TRIAL)], 0)
    first = core.pending_switch
    built_first = core.build(first)  # the first build runs while the second switch arrives
    out = core.tick([SwitchScenario("texture", {}, 2)], MS)
    assert any(r[:2] == ["log", "warning"] and "superseded" in r[2] for r in list(map(sent, out.records)))
    assert not core.install(first, built_first), "a superseded build is not installed"
    assert core.sim.scenario.id == "contact-angle-v1"
    second = core.pending_switch
    assert core.install(second, core.build(second))
    assert core.sim.scenario.id == "texture-v1" and core.sim.data.trial is None, "the first switch's trial went with it"
    assert make.built == ["stiffness-v1", "texture-v1"]


def test_a_failed_build_is_reported_and_the_running_scenario_goes_on():
    core, _ = off_tick_core()
    out = core.tick([SwitchScenario("no-such-scenario", {}, 0)], 0)
    assert core.pending_switch is None and any("no-such-scenario" in r[2] for r in list(map(sent, out.records)) if r[0] == "log"), \
        "an unknown name is refused at once"
    core.tick([SwitchScenario("stiffness", {"middle_level": "bad"}, 0), Trial(TRIAL)], MS)
    switch = core.pending_switch
    try:
        core.build(switch)
    except Exception as exc:  # noqa: BLE001 - what the builder thread catches
        core.abandon(switch, repr(exc))
    out = core.tick((), 2 * MS)
    assert core.pending_switch is None and core.sim.scenario.id == "contact-angle-v1"
    texts = [r[2] for r in list(map(sent, out.records)) if r[0] == "log"]
    assert any("record scenario failed" in t for t in texts) and any("trial record" in t for t in texts)
    announced = [r[1] for r in list(map(sent, out.records)) if r[0] == "scenario"]
    assert [(a["id"], a["failed"]) for a in announced] == [("contact-angle-v1", "stiffness")], \
        "the hub hears that the switch it sent will not come, and what runs instead"


def test_without_build_off_tick_apply_builds_and_installs_at_once():
    core = Loop(Simulation(ContactAngle()))
    core.apply(SwitchScenario("stiffness", {}, 0), 0)
    core.apply(Trial(TRIAL), 0)
    assert core.pending_switch is None and core.sim.scenario.id == "stiffness-v1" and core.sim.data.trial.index == 5


def test_the_builder_warms_up_off_the_calling_thread_then_builds_the_pending_switch(monkeypatch):
    import sys
    import threading
    import time

    from server.loop import builder as builder_module

    imported = []  # (module, thread name)
    real = builder_module.importlib.import_module
    monkeypatch.setattr(builder_module.importlib, "import_module",
                        lambda name: imported.append((name, threading.current_thread().name)) or real(name))
    core, make = off_tick_core()
    builder = builder_module.SwitchBuilder(core)
    builder.warm_up(("colorsys",))
    core.tick([SwitchScenario("stiffness", {}, 0)], MS)
    assert builder.busy and imported == [], "nothing is imported before between_ticks"
    deadline = time.monotonic() + 10
    while core.sim.scenario.id != "stiffness-v1" and time.monotonic() < deadline:
        builder.between_ticks()
        time.sleep(0.001)
    assert imported == [("colorsys", "loop-warm-up")] and "colorsys" in sys.modules
    assert make.built == ["stiffness-v1"], "the pending switch was built after the warm-up"
    assert not builder.busy and sys.getswitchinterval() > 0.001, "the switch interval is restored"
