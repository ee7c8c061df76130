"""The positioning agent on the virtual rig (issue 7): it completes trials with every cue law on
the FingerTac and with the FerroVibe's 3-DoF guidance, deciding depth only from the actuator
edges of the firmware core; a cue that lies about depth makes it fail visibly."""

from dataclasses import replace

import pytest

from server.core.cues import PulseTrain, Tilt
from devices.profiles import profile_by_model
from server.simulate.agent import AgentParams, GaveUp, PositioningAgent
from server.simulate.virtual_device import VirtualDevice
from server.simulate.virtual_hub import VirtualHub
from server.ipc.records import State


def run(cue: str, obj: str, model: str, fault=None, timeout_s: float = 90.0):
    device = VirtualDevice(model, profile_by_model(model), fault=fault)
    hub = VirtualHub({model: device})
    events = []
    hub.listeners.append(lambda r: events.extend(r.view["events"]) if type(r) is State else None)
    hub.switch_scenario("positioning", {"cue": cue})
    hub.set_trial("main", {"object": obj, "cue": cue}, 0)
    PositioningAgent(hub, device.feel, AgentParams(trial_timeout_s=timeout_s)).run_trial(obj, cue)
    return next(e for e in events if e["name"] == "trial_done"), device


@pytest.mark.parametrize("cue, obj, model", [
    ("P1", "cube_a", "fingertac"), ("P2", "sphere", "fingertac"), ("P3", "cube_b", "fingertac"),
    ("P4", "cube_a", "fingertac"), ("continuous-at-target", "sphere", "fingertac"),
    ("none-at-target", "cube_b", "fingertac"), ("3dof", "cube_a", "ferrovibe"), ("3dof", "sphere", "ferrovibe"),
])
def test_the_agent_completes_a_trial_by_feel(cue, obj, model):
    done, device = run(cue, obj, model)
    assert done["object"] == obj and 2.0 < done["completion_s"] < 60.0
    assert done["hold_depth_error_mean"] <= 0.05, "held within the target zone for the 2 s"
    assert any(e.gate for e in device.edges), "it had something to feel: the device played"


def mirror_depth(cues):
    """Front and back swapped on the magnet: the tilt sends the finger the wrong way in depth."""
    return tuple(replace(c, direction_deg=(180.0 - c.direction_deg) % 360.0) if isinstance(c, Tilt) else c
                 for c in cues)


def invert_rate(cues):
    """Pulse rate falling instead of rising toward the target."""
    return tuple(replace(c, t_off_ms=max(0.0, 1000.0 - c.t_off_ms)) if isinstance(c, PulseTrain) else c
                 for c in cues)


@pytest.mark.parametrize("cue, model, fault", [("3dof", "ferrovibe", mirror_depth), ("P1", "fingertac", invert_rate)])
def test_a_lying_cue_makes_it_fail_visibly(cue, model, fault):
    with pytest.raises(GaveUp, match="no insertion after 30 s"):
        run(cue, "cube_b", model, fault=fault, timeout_s=30.0)
