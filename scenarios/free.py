"""Free exploration of any scene: the god-object and contact only, no task logic, no cues.

Used when a scene comes from a file (`viestac render --scene FILE.json`, `viestac serve
--scene FILE.json`): researchers can feel out a custom scene or re-render recorded trajectories
through it without writing a scenario.
"""

from __future__ import annotations

from server.core.scenario import ScenarioOutput, TickContext, Trial
from server.core.scene import Scene

_NOTHING = ScenarioOutput()


class FreeExploration:
    id = "free-v1"
    title = "Free exploration of a scene file (no cues)"
    PARAMS = ()
    TRIAL_PARAMS = ()
    CONTROLS = ()
    SUBTASKS = ()
    REQUIRES = ()

    def __init__(self, scene: Scene | None = None):
        self.scene = scene

    def build_scene(self) -> Scene:
        if self.scene is None:
            raise ValueError("free exploration needs a scene (pass --scene FILE.json)")
        return self.scene

    def reset(self, seed: int) -> None:
        """No state."""

    def step(self, ctx: TickContext) -> ScenarioOutput:
        return _NOTHING

    def set_trial(self, trial: Trial | None) -> None:
        """No trials."""

    def on_input(self, key: str, action: str, value=None) -> None:
        """No keys."""
