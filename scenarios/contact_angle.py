"""Scenario 1, contact angle (thesis §4.1.1 and §5.2, Algorithm 1).

A hemisphere of radius 0.6 stands on a ground plane, seen by an orthographic camera 5 m away,
so it looks like a half circle. While the HIP is in contact with it, the contact angle is
a = acos(ref·v / (|ref||v|)) − 90 degrees with ref = (0, r, 0) and v = centre − HIP, so the
bottom-left point gives −90, the top 0 and the bottom-right +90. A FerroVibe shows it as a tilt
toward −a (mod 360): −90 → 90° (right side), 0 → 0° (front), +90 → 270° (left side), at a
constant magnitude.

Study aids (thesis §5.2.2): in training the angle scale (a protractor around the arc) and the
current angle are shown; in trial and main phases both are hidden, since the participant must
judge from touch alone. The experimenter "taps" the object at an angle: the HIP is placed on
the arc at that angle and held there (the thesis used a Falcon to hold it steady) until
released or until the main trial's time limit (30 s) runs out.
"""

from __future__ import annotations

import math
from typing import Any

from server.core.cues import Tilt, tilt_direction
from server.core.scenario import (Control, Param, Pending, ScenarioOutput, SubTask, TickContext, Trial,
                                  in_contact_with)
from server.core.haptics.primitives import Hemisphere, Plane, Pose
from server.core.scene import AngleScale, Camera, Material, Scene, SceneObject
from server.core.tool import DEFAULT_PROXY_RADIUS

RADIUS = 0.6
CENTRE = (0.0, 0.0, 0.0)
DOME_ID = "hemisphere"
SCALE_ID = "angle_scale"
PROXY_RADIUS = DEFAULT_PROXY_RADIUS  # the scene's god-object radius (Scene default)
TAP_DEPTH = 0.01           # how far a tap presses the HIP past the proxy: a firm, steady contact
STUDY_ANGLES = (-90.0, -70.0, -50.0, -30.0, -10.0, 10.0, 30.0, 50.0, 70.0, 90.0)


def contact_angle_deg(point, centre=CENTRE, radius: float = RADIUS) -> float:
    """Algorithm 1: the angle in [−90, +90] degrees of `point` around the hemisphere."""
    v = (centre[0] - point[0], centre[1] - point[1], centre[2] - point[2])
    norm_v = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if norm_v == 0.0:
        return 0.0  # at the centre every direction is as good; report the top
    cos_a = (radius * v[1]) / (radius * norm_v)  # ref = (0, r, 0)
    # rounded to 1e-9 degrees: a tap at 50 reads 50, not 49.99999999999999
    return round(math.degrees(math.acos(max(-1.0, min(1.0, cos_a)))) - 90.0, 9)


def point_at_angle(angle_deg: float, distance: float, centre=CENTRE) -> tuple[float, float, float]:
    """The inverse of Algorithm 1 on the arc facing the camera: the point at `distance` from the
    centre whose contact angle is `angle_deg` (−90 left, 0 top, +90 right)."""
    a = math.radians(angle_deg)
    return (centre[0], centre[1] + distance * math.sin(a), centre[2] + distance * math.cos(a))


class ContactAngle:
    id = "contact-angle-v1"
    title = "Contact angle (hemisphere, Algorithm 1)"
    PARAMS = (
        Param("magnitude_pct", "number", "tilt magnitude shown at every angle", 100.0, 0.0, 100.0, unit="%"),
        Param("stiffness_n_per_m", "number", "god-object spring of dome and ground", 1000.0, 0.0, 1e6, unit="N/m"),
        Param("probe", "choice", "the point Algorithm 1 reads: the HIP (as the thesis) or the god-object proxy "
              "(the same angle on the dome, robust when a tracker sinks deep)", "hip", choices=("hip", "proxy")),
    )
    TRIAL_PARAMS = (
        Param("angle_deg", "number", "the angle the experimenter taps at trial start (omit: none)", None,
              -90.0, 90.0, unit="deg", optional=True),
        Param("time_limit_s", "number", "the tap is released after this long", 30.0, 1.0, 600.0, unit="s"),
    )
    CONTROLS = (
        Control("tap_angle", "place the HIP on the arc at this angle and hold it there", "operator",
                Param("angle_deg", "number", "contact angle, -90 (left) .. +90 (right)", 0.0, -90.0, 90.0, unit="deg")),
        Control("release", "release a held tap; the tracker drives the HIP again", "operator"),
        Control("scale", "show or hide the angle scale", "operator",
                Param("shown", "bool", "true shows the scale", True)),
    )
    SUBTASKS = (
        SubTask("angles", "Contact angle discrimination (thesis §5.2)",
                tuple({"angle_deg": a} for a in STUDY_ANGLES),
                Param("answer_deg", "number", "the angle the participant names", 0.0, -90.0, 90.0, unit="deg"),
                practice_trials=3, training_s=120.0, time_limit_s=30.0,
                question="Which angle do you feel?"),
    )
    REQUIRES = ("macro_roughness",)

    def __init__(self, magnitude_pct: float = 100.0, stiffness_n_per_m: float = 1000.0, probe: str = "hip"):
        if not 0.0 <= magnitude_pct <= 100.0:
            raise ValueError("magnitude_pct must be in [0, 100]")
        self.magnitude_pct = magnitude_pct
        self.stiffness_n_per_m = stiffness_n_per_m
        self.probe = probe
        self.reset(0)

    def build_scene(self) -> Scene:
        ground = SceneObject("ground", Plane((3.0, 3.0)), Pose(),
                             Material("#6f7378", stiffness_n_per_m=self.stiffness_n_per_m))
        dome = SceneObject(DOME_ID, Hemisphere(RADIUS), Pose(CENTRE),
                           Material("#3a7bd5", stiffness_n_per_m=self.stiffness_n_per_m))
        camera = Camera("orthographic", position=(5.0, 0.0, 0.35), target=(0.0, 0.0, 0.35), up=(0.0, 0.0, 1.0),
                        height=1.6)
        scale = AngleScale(SCALE_ID, CENTRE, RADIUS + 0.02)
        return Scene("contact-angle", (ground, dome), camera, hud_text="Touch the half circle", overlays=(scale,))

    def reset(self, seed: int) -> None:
        self.trial: Trial | None = None
        self.trial_start_s: float | None = None
        self.tap: float | None = None       # angle held, if any
        self.scale_override: bool | None = None
        self.pending = Pending()
        self._scale_shown: bool | None = None
        self._memo: tuple = (None, None, None, (), "")  # (point, trial, angle, cues, hud) of the last contact tick

    def set_trial(self, trial: Trial | None) -> None:
        self.trial = trial
        self.trial_start_s = None  # stamped by the next tick
        self.scale_override = None
        self._set_tap(trial.params["angle_deg"] if trial else None, "trial")

    def _set_tap(self, angle: float | None, why: str) -> None:
        if angle != self.tap:
            self.pending.emit("tap" if angle is not None else "release", angle_deg=angle, by=why)
        self.tap = angle

    def on_input(self, key: str, action: str, value: Any = None) -> None:
        if action == "up":
            return
        if key == "tap_angle":
            self._set_tap(float(value), "experimenter")
        elif key == "release":
            self._set_tap(None, "experimenter")
        elif key == "scale":
            self.scale_override = bool(value)

    def _training(self) -> bool:
        return self.trial is None or self.trial.phase == "training"

    def step(self, ctx: TickContext) -> ScenarioOutput:
        if self.trial is not None and self.trial_start_s is None:
            self.trial_start_s = ctx.t_s
        elapsed = ctx.t_s - self.trial_start_s if self.trial_start_s is not None else 0.0
        if self.trial is not None and self.tap is not None and elapsed >= self.trial.params["time_limit_s"]:
            self._set_tap(None, "time_limit")
        values: dict[str, Any] = {}
        if self.trial is not None:
            values["trial_s"] = round(elapsed, 3)
        if self.tap is not None:
            values["tap_deg"] = self.tap
        hold = point_at_angle(self.tap, RADIUS + PROXY_RADIUS - TAP_DEPTH) if self.tap is not None else None
        shown = self.scale_override if self.scale_override is not None else self._training()
        if shown != self._scale_shown:
            self.pending.visible[SCALE_ID] = self._scale_shown = shown

        if in_contact_with(ctx, (DOME_ID,)):
            point = ctx.hip if self.probe == "hip" else ctx.proxy
            memo = self._memo
            # The point is held between tracker samples (~8 ticks a sample): the same point and
            # trial give the same angle, cue and HUD, so the last tick's are this tick's.
            if memo[0] is not point or memo[1] is not self.trial:
                angle = contact_angle_deg(point)
                memo = self._memo = (point, self.trial, angle, (Tilt(tilt_direction(-angle), self.magnitude_pct),),
                                     self._hud(angle))
            values["angle_deg"], cues, hud = memo[2], memo[3], memo[4]
        else:
            cues, hud = (), self._hud(None)
        if ctx.refusals:  # a device that cannot show tilt says so; the participant must not just feel nothing
            hud = "; ".join(ctx.refusals)
        return self.pending.flush(cues=cues, hud=hud, values=values, hold_hip=hold)

    def _hud(self, angle: float | None) -> str:
        if self._training():
            return "" if angle is None else f"Angle {angle:+.0f}°"
        return f"{self.trial.title}: which angle do you feel?"
