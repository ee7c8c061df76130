"""Switches in flight are matched by number, not by scenario id (issue 33): the hub's scenario
control (server/hub/control.py) and the loop core (server/loop/tick.py) together, the loop
building off the tick as the loop process does."""

from devices.profiles import profile_by_model
from scenarios import registry
from server.hub.control import ScenarioControl
from server.ipc.records import ScenarioAnnounce
from server.loop.tick import Loop
from server.loop.simulation import Simulation

PROFILES = {model: profile_by_model(model) for model in ("ferrovibe", "fingertac")}


def rig():
    """A loop running stiffness (A) with middle_level 5, and the hub's control of it."""
    core = Loop(Simulation(registry.create("stiffness", middle_level=5), tick_hz=1000, seed=0),
                    build_off_tick=True)
    core.params = {"middle_level": 5, "labels": True}
    mailbox: list = []
    ctl = ScenarioControl(lambda record: mailbox.append(record) or True, lambda: PROFILES)
    heard = list(core.announce())
    return core, ctl, mailbox, heard


def deliver(core, ctl, mailbox, heard):
    """The loop reads its mailbox; the hub hears what it announced (in order)."""
    for record in mailbox:
        core.apply(record, 0)
    mailbox.clear()
    heard.extend(core.outbox)
    core.outbox = []
    for record in heard:
        if isinstance(record, ScenarioAnnounce):
            ctl.announced(record.info)
    heard.clear()


def build(core, ctl, heard):
    """The loop process builds the pending switch off the tick and installs it."""
    switch = core.pending_switch
    core.install(switch, core.build(switch))
    deliver(core, ctl, [], heard)


def test_a_to_b_to_a_with_new_parameters_targets_the_last_switch_until_the_loop_installs_it():
    core, ctl, mailbox, heard = rig()
    deliver(core, ctl, mailbox, heard)
    assert ctl.target()["params"] == {"middle_level": 5, "labels": True}
    ctl.set_trial(None)  # the loop announces A again when it reads this: before it reads the switches
    ctl.switch_scenario("contact-angle", force=True)  # B
    ctl.switch_scenario("stiffness", {"middle_level": 3}, seed=2)  # A again, with new parameters
    deliver(core, ctl, mailbox, heard)  # the old announcement of A arrives; B is superseded, A' is built
    assert ctl.target() == {"id": "stiffness-v1", "params": {"middle_level": 3, "labels": True}, "seed": 2}, \
        "A's old announcement does not settle the switch back to A with new parameters"
    assert ctl.scenario_cls.id == "stiffness-v1"
    build(core, ctl, heard)
    target = ctl.target()
    assert (target["id"], target["params"], target["seed"]) == ("stiffness-v1", {"middle_level": 3, "labels": True}, 2)
    assert target is ctl.state, "nothing in flight: the target is what the loop announced"


def test_a_failed_build_settles_its_switch_by_number():
    core, ctl, mailbox, heard = rig()
    deliver(core, ctl, mailbox, heard)
    ctl.switch_scenario("contact-angle", force=True)
    deliver(core, ctl, mailbox, heard)
    core.abandon(core.pending_switch, "no memory")
    deliver(core, ctl, [], heard)
    assert ctl.target() is ctl.state and ctl.state["id"] == "stiffness-v1", "stiffness goes on"
    assert ctl.scenario_cls.id == "stiffness-v1"
