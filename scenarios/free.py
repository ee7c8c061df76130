"""free-v1: free exploration of a scene, with no task and no trials: the god-object against the
scene's bodies, and a vibration on every finger whose debounced contact is on.

`viestac serve --scene FILE.json` runs it on the scene file (server/config.py); the loop hands
that scene to every free-v1 it builds, after a scenario switch too (server/loop/process.py).
`viestac render --scene FILE.json` re-renders a recorded trajectory through it. Without a scene
file (`--scenario free`, a switch on a server started without one) it explores a small sandbox
of primitives. Researchers can feel out a custom scene without writing a scenario.
"""

from __future__ import annotations

from server.core.cues import Vibration
from server.core.haptics.primitives import Box, Cylinder, Plane, Pose, Sphere
from server.core.scenario import ScenarioOutput, TickContext, Trial
from server.core.scene import Camera, Material, Scene, SceneObject

ID = "free-v1"
CONTACT_PCT = 100.0  # the vibration while a finger's debounced contact is on
_TOUCH = (Vibration(CONTACT_PCT),)
_NOTHING = ScenarioOutput()
_PRIMARY_TOUCHES = ScenarioOutput(cues=_TOUCH)


def sandbox() -> Scene:
    """The scene free-v1 explores when it is given none: a table top with three primitives."""
    material = Material("#3a7bd5")
    objects = (SceneObject("ground", Plane((3.0, 4.0)), Pose(), Material("#d9d4c7")),
               SceneObject("sphere", Sphere(0.4), Pose((0.0, -1.2, 0.4)), material),
               SceneObject("box", Box((0.6, 0.6, 0.6)), Pose((0.0, 0.0, 0.3)), material),
               SceneObject("cylinder", Cylinder(0.3, 0.8), Pose((0.0, 1.2, 0.0)), material))  # base at its origin
    camera = Camera("perspective", position=(4.0, 0.0, 2.4), target=(0.0, 0.0, 0.3), up=(0.0, 0.0, 1.0),
                    fov_deg=45.0)
    return Scene("free-sandbox", objects, camera, hud_text="Free exploration")


class FreeExploration:
    id = ID
    title = "Free exploration of a scene (a scene file with serve --scene)"
    PARAMS = ()
    TRIAL_PARAMS = ()
    CONTROLS = ()
    SUBTASKS = ()
    REQUIRES = ()  # a contact vibration; a device that cannot show it says so

    def __init__(self, scene: Scene | None = None):
        self.scene = scene

    def build_scene(self) -> Scene:
        return self.scene if self.scene is not None else sandbox()

    def reset(self, seed: int) -> None:
        """No state."""

    def step(self, ctx: TickContext) -> ScenarioOutput:
        others = {tool.name: _TOUCH for tool in ctx.tools[1:] if tool.contact}
        if others:
            return ScenarioOutput(cues=_TOUCH if ctx.contact else (), tool_cues=others)
        return _PRIMARY_TOUCHES if ctx.contact else _NOTHING

    def set_trial(self, trial: Trial | None) -> None:
        """No trials."""

    def on_input(self, key: str, action: str, value=None) -> None:
        """No keys."""
