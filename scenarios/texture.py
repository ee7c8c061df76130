"""Scenario 2, texture (thesis §4.1.2 and §5.3; docs/scenarios.md).

One 3 × 3 plane. While the HIP touches it, the plane moves under the HIP at a fixed velocity
(0.1 scene units/s by default) and the texture plays: a periodic signal of period P, on for
P/2 and off for P/2 (FerroVibe: tilted for P/2, flat for P/2). Fixing the velocity is the
point of the design: the same texture explored at different speeds feels different (§4.1.2),
so every participant gets the same one. The plane stops when the HIP leaves it, and wraps back
by 1 unit once it has travelled 1 unit, so a long exploration never runs off its edge.

Five textures by period: 2000..6000 µs = 500, 333.33, 250, 200, 166.67 Hz; 6000 µs is called
"roughest" and 2000 µs "smoothest" (the reference extremes). Study parts (§5.3.2):
- references: the two extremes, labelled (run them as training-phase trials), ~60 s;
- pairs (sub-task A): two textures in sequence (the experimenter switches with `next`), rated
  "second vs first" on a 7-point scale (1 much smoother, 4 same, 7 much rougher); five pairs,
  each texture against the 250 Hz reference;
- identification (sub-task B): up to 3 min training with labels (keys 1-5 choose), then one
  practice and five main trials, each texture once; the answer is the frequency.
Labels (the frequency) are shown in training and for references only, never in trials.
"""

from __future__ import annotations

from typing import Any

from server.core.cues import Texture
from server.core.scenario import Control, Param, Pending, ScenarioOutput, SubTask, TickContext, Trial, in_contact_with
from server.core.haptics.primitives import Plane, Pose
from server.core.scene import Camera, Material, Scene, SceneObject, Skin

PERIODS_US = (2000.0, 3000.0, 4000.0, 5000.0, 6000.0)
REFERENCE_US = 4000.0  # 250 Hz, the comparison standard of sub-task A
ROUGHEST_US, SMOOTHEST_US = 6000.0, 2000.0
PLANE_ID = "plane"
PLANE_SIZE = 3.0
WRAP = 1.0  # travel after which the plane jumps back (HIP within ±0.5 of the centre stays on it)
LIKERT = {1: "much smoother", 4: "same", 7: "much rougher"}


def frequency_hz(period_us: float) -> float:
    return 1e6 / period_us


def texture_name(period_us: float) -> str:
    extreme = {ROUGHEST_US: " (roughest)", SMOOTHEST_US: " (smoothest)"}.get(period_us, "")
    return f"{frequency_hz(period_us):.2f} Hz{extreme}".replace(".00 Hz", " Hz")


class TextureScenario:
    id = "texture-v1"
    title = "Texture (moving plane, five periods)"
    PARAMS = (
        Param("period_us", "choice", "texture played outside trials (free exploration)", 4000.0, choices=PERIODS_US,
              unit="us"),
        Param("velocity", "number", "plane speed under the HIP along +y while in contact (negative: -y)", 0.1,
              -2.0, 2.0, unit="units/s"),
        Param("intensity_pct", "number", "texture intensity / tilt magnitude", 100.0, 0.0, 100.0, unit="%"),
        Param("skin", "text", "an image on the plane, e.g. /skins/cork.svg or an LMT texture photo in "
              "clients/web/skins ('' = plain)", ""),
        Param("skin_tile", "number", "the skin repeats every this many scene units", 0.5, 0.01, 3.0),
    )
    TRIAL_PARAMS = (
        Param("period_us", "choice", "the texture (for a pair: the first one)", None, choices=PERIODS_US, unit="us"),
        Param("second_period_us", "choice", "a pair's second texture (omit: a single texture)", None,
              choices=PERIODS_US, unit="us", optional=True),
    )
    CONTROLS = (
        Control("next", "pairs: switch from the first to the second texture", "operator"),
        Control("texture", "training: play the texture of this period", "operator",
                Param("period_us", "choice", "period in microseconds", 4000.0, choices=PERIODS_US, unit="us")),
        *(Control(str(i + 1), f"training: play {texture_name(p)}", "operator") for i, p in enumerate(PERIODS_US)),
    )
    SUBTASKS = (
        SubTask("references", "Reference extremes (thesis §5.3.2)",
                ({"period_us": ROUGHEST_US}, {"period_us": SMOOTHEST_US}), None, training_s=60.0),
        SubTask("pairs", "Sub-task A: second vs first",
                tuple({"period_us": REFERENCE_US, "second_period_us": p} for p in PERIODS_US),
                Param("rating", "int", "7-point scale", 4, 1, 7, labels=LIKERT),
                question="How much smoother or rougher did the second texture feel compared to the first one?"),
        SubTask("identification", "Sub-task B: which frequency",
                tuple({"period_us": p} for p in PERIODS_US),
                Param("answer_hz", "choice", "the frequency named", None,
                      choices=tuple(round(frequency_hz(p), 2) for p in PERIODS_US), unit="Hz"),
                practice_trials=1, training_s=180.0, question="Which texture is this?"),
    )
    REQUIRES = ("fine_roughness",)

    def __init__(self, period_us: float = 4000.0, velocity: float = 0.1, intensity_pct: float = 100.0,
                 skin: str = "", skin_tile: float = 0.5):
        self.free_period_us = period_us
        self.velocity = velocity
        self.intensity_pct = intensity_pct
        self.skin = Skin(skin, (skin_tile, skin_tile)) if skin else None
        self.reset(0)

    def build_scene(self) -> Scene:
        plane = SceneObject(PLANE_ID, Plane((PLANE_SIZE, PLANE_SIZE)), Pose(),
                            Material("#b89f7a", skin=self.skin))
        camera = Camera("perspective", position=(3.2, 0.0, 2.0), target=(0.0, 0.0, 0.0), up=(0.0, 0.0, 1.0),
                        fov_deg=45.0)
        return Scene("texture", (plane,), camera, hud_text="Touch the plane")

    def reset(self, seed: int) -> None:
        self.trial: Trial | None = None
        self.offset = 0.0
        self.last_t: float | None = None
        self.second = False  # pairs: playing the second texture
        self.chosen: float | None = None  # training choice of the experimenter
        self.pending = Pending()

    def set_trial(self, trial: Trial | None) -> None:
        self.trial = trial
        self.second = False
        self.chosen = None

    def on_input(self, key: str, action: str, value: Any = None) -> None:
        if action == "up":
            return
        if key == "next" and self._is_pair() and not self.second:
            self.second = True
            self.pending.emit("second", period_us=self.trial.params["second_period_us"])
        elif key == "texture":
            self._choose(float(value))
        elif key in ("1", "2", "3", "4", "5"):
            self._choose(PERIODS_US[int(key) - 1])

    def _choose(self, period_us: float) -> None:
        if self.trial is None or self.trial.phase == "training":
            self.chosen = period_us
            self.pending.emit("texture", period_us=period_us)

    def _is_pair(self) -> bool:
        return self.trial is not None and self.trial.params["second_period_us"] is not None

    def current_period_us(self) -> float:
        if self.chosen is not None:
            return self.chosen
        if self.trial is None:
            return self.free_period_us
        p = self.trial.params
        return p["second_period_us"] if self.second else p["period_us"]

    def _labelled(self) -> bool:
        """Frequencies are named in training (incl. the reference extremes), never in trials."""
        return self.trial is None or self.trial.phase == "training"

    def step(self, ctx: TickContext) -> ScenarioOutput:
        dt = 0.0 if self.last_t is None else ctx.t_s - self.last_t
        self.last_t = ctx.t_s
        period = self.current_period_us()
        values: dict[str, Any] = {"period_us": period, "frequency_hz": round(frequency_hz(period), 2),
                                  "plane_offset": round(self.offset, 6)}
        touching = in_contact_with(ctx, (PLANE_ID,)) is not None
        cues: tuple = ()
        if touching:
            self.offset += self.velocity * dt
            if abs(self.offset) >= WRAP:  # jump back a whole unit: the skin tiles evenly, the HIP stays on
                self.offset -= WRAP if self.offset > 0 else -WRAP
            self.pending.poses[PLANE_ID] = Pose((0.0, self.offset, 0.0))
            cues = (Texture(period, 0.5, self.intensity_pct),)
        hud = self._hud(period)
        if ctx.refusals:
            hud = "; ".join(ctx.refusals)
        return self.pending.flush(cues=cues, hud=hud, values=values)

    def _hud(self, period: float) -> str:
        if self._is_pair():
            return f"Pair {self.trial.index + 1}: {'second' if self.second else 'first'} texture"
        if self._labelled():
            return f"Texture {texture_name(period)}"
        return f"{self.trial.title}: which texture is this?"
