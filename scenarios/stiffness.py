"""Scenario 3, stiffness (thesis §4.1.3 and §5.4; docs/scenarios.md).

Three static spheres of radius 0.4 on a plane: left grey = the softest reference (level 1),
middle green = the test sphere, right red = the stiffest reference (level 10). Each is a
virtual spring, F = k · penetration, with k = 1 N/m at level 1 and 10·L N/m at level L = 2..10.
While the HIP touches a sphere the scenario emits a `Stiffness` cue: its spring constant and its
place between the softest and stiffest level; a device that encodes stiffness as vibration
turns that into a pulse rate (devices/encoder.py: 1 Hz at level 1 … 10 Hz at level 10, t_on 50 ms,
t_off = 1000/rate − 50 ms). Nothing visual changes with stiffness (§5.4.1: no deformation shown).

Keys (§4.1.3): `n` gives the middle sphere a random level; ↑/↓ change the right sphere by one
level (magnitude production; only outside estimation trials, where the right sphere must stay
the reference); `r` starts/stops recording, and the left sphere is hidden (and untouchable)
while recording, as in §5.4.1. Every key press is an event with its tick.
"""

from __future__ import annotations

import random
from typing import Any

from server.core.cues import Stiffness
from server.core.scenario import Control, Param, Pending, ScenarioOutput, SubTask, TickContext, Trial, in_contact_with
from server.core.haptics.primitives import Plane, Pose, Sphere
from server.core.scene import Camera, Label, Material, Scene, SceneObject

LEVELS = tuple(range(1, 11))
SPHERE_RADIUS = 0.4
SPACING = 1.1
LEFT, MIDDLE, RIGHT = "left", "middle", "right"
SPHERES = {LEFT: (-SPACING, "#8c8c8c"), MIDDLE: (0.0, "#3cb44b"), RIGHT: (SPACING, "#d62728")}


def level_k(level: int) -> float:
    """Spring constant of a level: 1 N/m at level 1, 10·L N/m for L = 2..10."""
    if level not in LEVELS:
        raise ValueError(f"stiffness level must be 1..10, got {level!r}")
    return 1.0 if level == 1 else 10.0 * level


def level_cue(level: int) -> Stiffness:
    return Stiffness(level_k(level), (level - 1) / (len(LEVELS) - 1))


class StiffnessScenario:
    id = "stiffness-v1"
    title = "Stiffness (three spheres, magnitude estimation and production)"
    PARAMS = (
        Param("middle_level", "int", "level of the middle sphere outside trials", 5, 1, 10),
        Param("labels", "bool", "show the reference levels (1 and 10) under the outer spheres", True),
    )
    TRIAL_PARAMS = (
        Param("mode", "choice", "magnitude estimation (name the middle level) or production (match it with the "
              "right sphere)", None, choices=("estimation", "production")),
        Param("level", "int", "the middle sphere's level", None, 1, 10),
        Param("start_level", "int", "production: the right sphere's level at the start", 10, 1, 10),
    )
    CONTROLS = (
        Control("n", "give the middle sphere a random level", "operator"),
        Control("ArrowUp", "right sphere one level stiffer (production)"),
        Control("ArrowDown", "right sphere one level softer (production)"),
        Control("r", "start/stop recording; the left sphere is hidden while recording", "operator"),
    )
    SUBTASKS = (
        SubTask("estimation", "Magnitude estimation (thesis §5.4)",
                tuple({"mode": "estimation", "level": level} for level in LEVELS),
                Param("answer_level", "int", "the level the participant names, 1..10", None, 1, 10),
                question="How stiff is the middle sphere, from 1 (left) to 10 (right)?"),
        SubTask("production", "Magnitude production (thesis §5.4)",
                tuple({"mode": "production", "level": level} for level in LEVELS),
                None,  # the produced level and the key presses are recorded by the scenario
                question="Change the right sphere with the arrow keys until it feels as stiff as the middle one."),
    )
    REQUIRES = ("stiffness",)

    def __init__(self, middle_level: int = 5, labels: bool = True):
        level_k(middle_level)
        self.free_middle = middle_level
        self.labels = labels
        self.reset(0)

    def build_scene(self) -> Scene:
        ground = SceneObject("ground", Plane((2.0, 4.0)), Pose(), Material("#d9d4c7"))  # 2 deep, 4 wide
        spheres = tuple(SceneObject(sid, Sphere(SPHERE_RADIUS), Pose((0.0, y, SPHERE_RADIUS)),
                                    Material(color, stiffness_n_per_m=level_k(self._initial_level(sid))))
                        for sid, (y, color) in SPHERES.items())
        camera = Camera("orthographic", position=(5.0, 0.0, 0.55), target=(0.0, 0.0, 0.55), up=(0.0, 0.0, 1.0),
                        height=2.6)
        overlays = ()
        if self.labels:
            overlays = (Label("left_label", (0.0, -SPACING, 1.05), "1"), Label("right_label", (0.0, SPACING, 1.05), "10"))
        return Scene("stiffness", (ground, *spheres), camera, hud_text="Tap the spheres", overlays=overlays)

    def _initial_level(self, sphere: str) -> int:
        return {LEFT: 1, MIDDLE: self.free_middle, RIGHT: 10}[sphere]

    def reset(self, seed: int) -> None:
        self.rng = random.Random(seed)
        self.trial: Trial | None = None
        self.levels = {LEFT: 1, MIDDLE: self.free_middle, RIGHT: 10}
        self.recording = False
        self.recording_since: float | None = None
        self.recorded_s: float | None = None
        self._t = 0.0
        self.pending = Pending()

    def set_trial(self, trial: Trial | None) -> None:
        self.trial = trial
        self._set_recording(False, "trial")
        self.recorded_s = None
        if trial is None:
            self._set_level(MIDDLE, self.free_middle)
            self._set_level(RIGHT, 10)
        else:
            self._set_level(MIDDLE, trial.params["level"])
            self._set_level(RIGHT, trial.params["start_level"] if trial.params["mode"] == "production" else 10)

    def _set_level(self, sphere: str, level: int) -> None:
        if self.levels[sphere] != level:
            self.levels[sphere] = level
            self.pending.stiffness[sphere] = level_k(level)

    def _set_recording(self, on: bool, why: str) -> None:
        if on == self.recording:
            return
        self.recording = on
        if on:
            self.recording_since = self._t
            self.recorded_s = None
        elif self.recording_since is not None:
            self.recorded_s = self._t - self.recording_since
            self.recording_since = None
        # §5.4.1: while recording only the spheres to be matched are shown (and touchable)
        self.pending.touchable[LEFT] = self.pending.visible[LEFT] = not on
        if self.labels:
            self.pending.visible["left_label"] = not on
        self.pending.emit("recording", on=on, by=why, right_level=self.levels[RIGHT],
                          middle_level=self.levels[MIDDLE])
        if not on and why == "key" and self.trial is not None and self.trial.params["mode"] == "production":
            # the production trial's result: the trial record keeps it as its metrics
            self.pending.finish({"produced_level": self.levels[RIGHT], "target_level": self.levels[MIDDLE],
                                 "match_time_s": round(self.recorded_s, 6)})

    def _production_keys(self) -> bool:
        return self.trial is None or self.trial.params["mode"] == "production"

    def on_input(self, key: str, action: str, value: Any = None) -> None:
        if action == "up":
            return
        before = self.levels[RIGHT]
        if key == "n":
            self._set_level(MIDDLE, self.rng.choice(LEVELS))
        elif key in ("ArrowUp", "ArrowDown") and self._production_keys():
            self._set_level(RIGHT, min(10, max(1, before + (1 if key == "ArrowUp" else -1))))
        elif key == "r":
            self._set_recording(not self.recording, "key")
            return
        else:
            return
        self.pending.emit("key", key=key, right_level=self.levels[RIGHT], recording=self.recording)

    def step(self, ctx: TickContext) -> ScenarioOutput:
        self._t = ctx.t_s
        touched = in_contact_with(ctx, (LEFT, MIDDLE, RIGHT))
        cues = (level_cue(self.levels[touched]),) if touched else ()
        values: dict[str, Any] = {"middle_level": self.levels[MIDDLE], "right_level": self.levels[RIGHT],
                                  "recording": self.recording}
        if touched:
            values["touching"] = touched
        if self.recording and self.recording_since is not None:
            values["recording_s"] = round(ctx.t_s - self.recording_since, 3)
        elif self.recorded_s is not None:
            values["match_time_s"] = round(self.recorded_s, 3)
            values["produced_level"] = self.levels[RIGHT]
        return self.pending.flush(cues=cues, hud=self._hud(ctx), values=values)

    def _hud(self, ctx: TickContext) -> str:
        if ctx.refusals:
            return "; ".join(ctx.refusals)
        if self.trial is None or self.trial.phase == "training":
            return "Tap the spheres: left is the softest (1), right the stiffest (10)"
        if self.trial.params["mode"] == "estimation":
            return f"{self.trial.title}: how stiff is the middle sphere (1-10)?"
        if self.recording:
            return f"{self.trial.title}: ↑/↓ until the right sphere feels like the middle one"
        return f"{self.trial.title}: tap the middle and the right sphere"
