"""Scenario 4, shape detection (thesis §4.1.4, Algorithm 2).

A cube (side 1, origin at its bottom centre), a sphere (radius 0.5) and a cone (base radius 0.5,
height 1), seen by an orthographic camera 5 m away, so they look like a square, a circle and a
triangle; same material for all. While the HIP touches one, the magnet tilts (Algorithm 2):
- cube: HIP.y ≤ c.y − 0.5 → 90°, 100 %; HIP.y ≥ c.y + 0.5 → 270°, 100 %;
  HIP.z ≥ c.z + 1.0 → 0°, 100 %; otherwise nothing;
- sphere: 100 %, direction from Algorithm 1 around its centre;
- cone: HIP.y ≤ c.y → 90°, 60 %; otherwise 270°, 60 %;
where c is the object's origin. Optionally a texture vibration plays at the same time, and the
tilt magnitude is lowered by a factor (§4.1.4: the magnet then leaves its position, which the
thesis found less clear).

Outside trials the three shapes stand side by side. A trial presents one shape, moved to the
centre, the others removed; with `hidden` it is touched but not drawn (tactile-only detection).
"""

from __future__ import annotations

from typing import Any

from server.core.cues import Texture, Tilt, tilt_direction
from server.core.scenario import Param, Pending, ScenarioOutput, SubTask, TickContext, Trial, in_contact_with
from scenarios.contact_angle import contact_angle_deg
from scenarios.texture import PERIODS_US
from server.core.haptics.primitives import Box, Cone, Plane, Pose, Sphere
from server.core.scene import Camera, Label, Material, Scene, SceneObject

SHAPES = ("cube", "sphere", "cone")
SIDE = 1.0
SPHERE_R = 0.5
CONE_R, CONE_H = 0.5, 1.0
GALLERY_Y = {"cube": -1.5, "sphere": 0.0, "cone": 1.5}
CUBE_TILT_PCT = SPHERE_TILT_PCT = 100.0
CONE_TILT_PCT = 60.0


def origin_pose(shape: str, y: float) -> Pose:
    """The object's pose for origin c = (0, y, 0) as Algorithm 2 defines it (cube: bottom centre,
    sphere: centre resting on the ground, cone: base centre). Our box primitive is centred."""
    z = {"cube": SIDE / 2, "sphere": SPHERE_R, "cone": 0.0}[shape]
    return Pose((0.0, y, z))


def algorithm2(shape: str, point, c) -> tuple[float, float] | None:
    """(tilt direction deg, magnitude %) for a point touching `shape` with origin `c`, or None."""
    if shape == "cube":
        if point[1] <= c[1] - 0.5:
            return 90.0, CUBE_TILT_PCT
        if point[1] >= c[1] + 0.5:
            return 270.0, CUBE_TILT_PCT
        if point[2] >= c[2] + 1.0:
            return 0.0, CUBE_TILT_PCT
        return None
    if shape == "sphere":
        return tilt_direction(-contact_angle_deg(point, c, SPHERE_R)), SPHERE_TILT_PCT
    if shape == "cone":
        return (90.0, CONE_TILT_PCT) if point[1] <= c[1] else (270.0, CONE_TILT_PCT)
    raise ValueError(f"unknown shape {shape!r}; known: {', '.join(SHAPES)}")


class ShapeScenario:
    id = "shape-v1"
    title = "Shape detection (cube, sphere, cone; Algorithm 2)"
    PARAMS = (
        Param("texture_period_us", "number", "concurrent texture vibration period (0 = none)", 0.0, 0.0, 6000.0,
              unit="us"),
        Param("texture_tilt_scale", "number", "tilt magnitude factor while the texture plays", 0.7, 0.0, 1.0),
        Param("probe", "choice", "the point Algorithm 2 reads: the HIP (as the thesis) or the god-object proxy "
              "(on the surface even when a tracker sinks deep)", "hip", choices=("hip", "proxy")),
        Param("labels", "bool", "name the shapes outside trials", True),
    )
    TRIAL_PARAMS = (
        Param("shape", "choice", "the shape presented at the centre", None, choices=SHAPES),
        Param("hidden", "bool", "touched but not drawn (tactile-only detection)", True),
    )
    CONTROLS = ()
    SUBTASKS = (
        SubTask("detection", "Shape detection by touch",
                tuple({"shape": s, "hidden": True} for s in SHAPES),
                Param("answer_shape", "choice", "the shape named", None, choices=SHAPES),
                practice_trials=1, question="Which shape do you feel?"),
    )
    REQUIRES = ("macro_roughness",)

    def __init__(self, texture_period_us: float = 0.0, texture_tilt_scale: float = 0.7, probe: str = "hip",
                 labels: bool = True):
        if texture_period_us and texture_period_us not in PERIODS_US:
            raise ValueError(f"texture_period_us must be 0 or one of {', '.join(str(int(p)) for p in PERIODS_US)}")
        self.texture_period_us = texture_period_us
        self.texture_tilt_scale = texture_tilt_scale
        self.probe = probe
        self.labels = labels
        self.reset(0)

    def build_scene(self) -> Scene:
        material = Material("#e08a2c")
        shapes = {"cube": Box((SIDE, SIDE, SIDE)), "sphere": Sphere(SPHERE_R), "cone": Cone(CONE_R, CONE_H)}
        objects = [SceneObject("ground", Plane((2.0, 5.0)), Pose(), Material("#d9d4c7"))]  # 2 deep, 5 wide
        objects += [SceneObject(name, shape, origin_pose(name, GALLERY_Y[name]), material)
                    for name, shape in shapes.items()]
        overlays = tuple(Label(f"{name}_label", (0.0, GALLERY_Y[name], 1.25), name) for name in SHAPES) \
            if self.labels else ()
        camera = Camera("orthographic", position=(5.0, 0.0, 0.6), target=(0.0, 0.0, 0.6), up=(0.0, 0.0, 1.0),
                        height=3.2)
        return Scene("shape", tuple(objects), camera, hud_text="Explore the shapes", overlays=overlays)

    def reset(self, seed: int) -> None:
        self.trial: Trial | None = None
        self.origins = {name: (0.0, GALLERY_Y[name], 0.0) for name in SHAPES}
        self.pending = Pending()

    def set_trial(self, trial: Trial | None) -> None:
        self.trial = trial
        for name in SHAPES:
            active = trial is None or trial.params["shape"] == name
            y = 0.0 if trial is not None and active else GALLERY_Y[name]
            self.origins[name] = (0.0, y, 0.0)
            self.pending.poses[name] = origin_pose(name, y)
            self.pending.touchable[name] = active
            self.pending.visible[name] = active and not (trial is not None and trial.params["hidden"])
            if self.labels:
                self.pending.visible[f"{name}_label"] = trial is None

    def on_input(self, key: str, action: str, value: Any = None) -> None:
        """No keys: the experimenter presents shapes as trials."""

    def step(self, ctx: TickContext) -> ScenarioOutput:
        touched = in_contact_with(ctx, SHAPES)
        cues: tuple = ()
        values: dict[str, Any] = {}
        if touched:
            point = ctx.hip if self.probe == "hip" else ctx.proxy
            tilt = algorithm2(touched, point, self.origins[touched])
            values["touching"] = touched
            if tilt is not None:
                direction, magnitude = tilt
                if self.texture_period_us:
                    cues = (Tilt(direction, magnitude * self.texture_tilt_scale), Texture(self.texture_period_us))
                else:
                    cues = (Tilt(direction, magnitude),)
                values["tilt_deg"], values["magnitude_pct"] = direction, magnitude
        return self.pending.flush(cues=cues, hud=self._hud(ctx), values=values)

    def _hud(self, ctx: TickContext) -> str:
        if ctx.refusals:
            return "; ".join(ctx.refusals)
        if self.trial is None or self.trial.phase == "training":
            return ""
        return f"{self.trial.title}: which shape do you feel?"
