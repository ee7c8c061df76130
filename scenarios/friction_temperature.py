"""Scenario 5, friction and temperature (thesis §4.1.5; docs/scenarios.md).

A static plane with static and dynamic friction, rendered by the god-object's friction cone
(the proxy sticks while the lateral pull stays inside μ_s, then slides lagging by μ_d), and the
three spheres of scenario 3 with temperatures. While the HIP touches the plane the scenario
emits a `Friction` cue with the coefficient that holds the proxy now (μ_s while sticking, μ_d
while sliding); on a sphere a `Temperature` cue with its temperature. A device that shows
neither dimension is refused before the scenario runs (devices/capability.py), and a device that
shows only one of them reports the other cue as refused in the HUD.
"""

from __future__ import annotations

from typing import Any

from server.core.cues import Friction, Temperature
from server.core.scenario import Param, ScenarioOutput, SubTask, TickContext, Trial, in_contact_with
from scenarios.stiffness import LEFT, MIDDLE, RIGHT, SPHERE_RADIUS, SPHERES
from server.core.haptics.primitives import Plane, Pose, Sphere
from server.core.scene import Camera, Label, Material, Scene, SceneObject

PLANE_ID = "plane"
TEMPERATURES_C = {LEFT: 20.0, MIDDLE: 32.0, RIGHT: 40.0}  # (default) cool, skin-neutral, warm


def _celsius(name: str, default: float, doc: str) -> Param:
    return Param(name, "number", doc, default, 0.0, 50.0, unit="°C")


def _mu(name: str, default: float, doc: str) -> Param:
    return Param(name, "number", doc, default, 0.0, 5.0)


class FrictionTemperature:
    id = "friction-temperature-v1"
    title = "Friction (plane) and temperature (three spheres)"
    PARAMS = (
        _mu("static_friction", 0.6, "μ_s of the plane"),
        _mu("dynamic_friction", 0.4, "μ_d of the plane (≤ μ_s)"),
        _celsius("left_c", TEMPERATURES_C[LEFT], "left sphere"),
        _celsius("middle_c", TEMPERATURES_C[MIDDLE], "middle sphere"),
        _celsius("right_c", TEMPERATURES_C[RIGHT], "right sphere"),
        Param("labels", "bool", "show the reference temperatures over the outer spheres", True),
    )
    TRIAL_PARAMS = (
        Param("middle_c", "number", "the middle sphere's temperature this trial", None, 0.0, 50.0, unit="°C",
              optional=True),
    )
    CONTROLS = ()
    SUBTASKS = (
        SubTask("temperature", "Temperature estimation between the references",
                tuple({"middle_c": c} for c in (22.0, 26.0, 30.0, 34.0, 38.0)),
                Param("answer_level", "int", "1 = as cool as the left sphere … 7 = as warm as the right one", None,
                      1, 7, labels={1: "as cool as left", 7: "as warm as right"}),
                question="How warm is the middle sphere between the left and the right one?"),
    )
    REQUIRES = ("friction", "temperature")

    def __init__(self, static_friction: float = 0.6, dynamic_friction: float = 0.4, left_c: float = 20.0,
                 middle_c: float = 32.0, right_c: float = 40.0, labels: bool = True):
        if dynamic_friction > static_friction:
            raise ValueError("dynamic_friction must not exceed static_friction (the friction cone needs μ_d ≤ μ_s)")
        self.static_friction = static_friction
        self.dynamic_friction = dynamic_friction
        self.free_temperatures = {LEFT: left_c, MIDDLE: middle_c, RIGHT: right_c}
        self.labels = labels
        self.reset(0)

    def build_scene(self) -> Scene:
        plane = SceneObject(PLANE_ID, Plane((4.0, 3.0)), Pose(),
                            Material("#9fb7c9", static_friction=self.static_friction,
                                     dynamic_friction=self.dynamic_friction))
        # the spheres stand at the back half of the plane, the front half is free for sliding
        spheres = tuple(SceneObject(sid, Sphere(SPHERE_RADIUS), Pose((-0.8, y, SPHERE_RADIUS)), Material(color))
                        for sid, (y, color) in SPHERES.items())
        overlays = ()
        if self.labels:
            overlays = tuple(Label(f"{sid}_label", (-0.8, SPHERES[sid][0], 1.05), f"{self.free_temperatures[sid]:g} °C")
                             for sid in (LEFT, RIGHT))
        camera = Camera("perspective", position=(4.0, 0.0, 2.4), target=(-0.3, 0.0, 0.2), up=(0.0, 0.0, 1.0),
                        fov_deg=45.0)
        return Scene("friction-temperature", (plane, *spheres), camera,
                     hud_text="Slide on the plane, touch the spheres", overlays=overlays)

    def reset(self, seed: int) -> None:
        self.trial: Trial | None = None
        self.temperatures = dict(self.free_temperatures)

    def set_trial(self, trial: Trial | None) -> None:
        self.trial = trial
        self.temperatures = dict(self.free_temperatures)
        if trial is not None and trial.params["middle_c"] is not None:
            self.temperatures[MIDDLE] = trial.params["middle_c"]

    def on_input(self, key: str, action: str, value: Any = None) -> None:
        """No keys."""

    def step(self, ctx: TickContext) -> ScenarioOutput:
        touched = in_contact_with(ctx, (LEFT, MIDDLE, RIGHT, PLANE_ID))
        cues: tuple = ()
        values: dict[str, Any] = {}
        if touched == PLANE_ID:
            mu = self.static_friction if ctx.sticking else self.dynamic_friction
            cues = (Friction(mu),)
            values.update(touching=touched, friction=mu, sticking=ctx.sticking)
        elif touched is not None:
            celsius = self.temperatures[touched]
            cues = (Temperature(celsius),)
            values.update(touching=touched, celsius=celsius)
        hud = "; ".join(ctx.refusals)
        if not hud and self.trial is not None and self.trial.phase != "training":
            hud = f"{self.trial.title}: how warm is the middle sphere?"
        return ScenarioOutput(cues=cues, hud=hud, values=values)
