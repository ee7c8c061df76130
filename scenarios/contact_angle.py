"""Scenario 1, contact angle (thesis §4.1.1, spec.md Algorithm 1).

A hemisphere of radius 0.6 stands on a ground plane, seen by an orthographic camera 5 m away,
so it looks like a half circle. While the HIP is in contact with it, the contact angle is
a = acos(ref·v / (|ref||v|)) − 90 degrees with ref = (0, r, 0) and v = centre − HIP, so the
bottom-left point gives −90, the top 0 and the bottom-right +90. A FerroVibe shows it as a tilt
toward −a (mod 360): −90 → 90° (right side), 0 → 0° (front), +90 → 270° (left side), at a
constant magnitude.
"""

from __future__ import annotations

import math

from devices.cues import Tilt, tilt_direction
from scenarios.base import ScenarioOutput, TickContext
from server.haptics.primitives import Hemisphere, Plane, Pose
from server.scene import Camera, Material, Scene, SceneObject

RADIUS = 0.6
CENTRE = (0.0, 0.0, 0.0)
DOME_ID = "hemisphere"


def contact_angle_deg(hip, centre=CENTRE, radius: float = RADIUS) -> float:
    """Algorithm 1: the angle in [−90, +90] degrees of the HIP around the hemisphere."""
    v = (centre[0] - hip[0], centre[1] - hip[1], centre[2] - hip[2])
    norm_v = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if norm_v == 0.0:
        return 0.0  # HIP at the centre: every direction is as good; report the top
    cos_a = (radius * v[1]) / (radius * norm_v)  # ref = (0, r, 0)
    return math.degrees(math.acos(max(-1.0, min(1.0, cos_a)))) - 90.0


class ContactAngle:
    id = "contact-angle-v1"
    title = "Contact angle (hemisphere, Algorithm 1)"

    def __init__(self, magnitude_pct: float = 100.0, stiffness_n_per_m: float = 1000.0):
        if not 0.0 <= magnitude_pct <= 100.0:
            raise ValueError("magnitude_pct must be in [0, 100]")
        self.magnitude_pct = magnitude_pct
        self.stiffness_n_per_m = stiffness_n_per_m

    def build_scene(self) -> Scene:
        ground = SceneObject("ground", Plane((3.0, 3.0)), Pose(),
                             Material("#6f7378", stiffness_n_per_m=self.stiffness_n_per_m))
        dome = SceneObject(DOME_ID, Hemisphere(RADIUS), Pose(CENTRE),
                           Material("#3a7bd5", stiffness_n_per_m=self.stiffness_n_per_m))
        camera = Camera("orthographic", position=(5.0, 0.0, 0.35), target=(0.0, 0.0, 0.35), up=(0.0, 0.0, 1.0), height=1.6)
        return Scene("contact-angle", (ground, dome), camera, hud_text="Touch the half circle")

    def reset(self, seed: int) -> None:
        """Stateless between ticks: nothing to reset."""

    def step(self, ctx: TickContext) -> ScenarioOutput:
        touching_dome = ctx.contact and (DOME_ID in ctx.touching or ctx.nearest == DOME_ID)
        if not touching_dome:
            return ScenarioOutput()
        angle = contact_angle_deg(ctx.hip)
        tilt = Tilt(tilt_direction(-angle), self.magnitude_pct)
        # A device that cannot show tilt says so; the participant must not just feel nothing.
        hud = "; ".join(ctx.refusals)
        return ScenarioOutput(cues=(tilt,), hud=hud, values={"angle_deg": angle})

    def on_input(self, key: str, action: str) -> None:
        """No keys in the free-exploration slice; the study controls come with the scenario issue."""
