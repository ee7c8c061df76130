"""Scenario 8, hot wire (thesis §4.2.4; docs/scenarios.md).

A green path (segments, a circle or a spiral) runs above the table from a start to a red target
hole. The participant brings the HIP (sphere r 0.06) to the start, then moves its centre along
the path to the target. The deviation is the distance from the HIP centre to its nearest
projection on the path: within the allowed `threshold` (the difficulty) no cue; beyond it the
intensity and pulse rate rise with the deviation up to `max_distance`; beyond that the cue stops
(scenarios/guidance.hot_wire_cue).

Moving-target variant (`target_speed` > 0): a red marker leaves the start when the run starts and
travels along the path at that speed; the participant keeps the HIP with it, and the deviation
is measured to the marker instead of to the whole path (pursuit tracking).

Metrics (values, and at the target `finished` with a `trial_done` event): completion time
(start → target), time outside the threshold, mean and maximum deviation, the HIP's trajectory
length, and for a moving target the mean distance to it.
"""

from __future__ import annotations

import math
from typing import Any


from server.core.scenario import Control, Param, Pending, ScenarioOutput, TickContext, Trial
from scenarios.guidance import hot_wire_cue
from scenarios.positioning import TABLE
from scenarios.wire_path import PATH_KINDS, Path, make_path
from server.core.haptics.primitives import Plane, Pose, Sphere
from server.core.scene import Camera, Material, Mesh, Scene, SceneObject

from server.core.tool import DEFAULT_PROXY_RADIUS as HIP_RADIUS
START_RADIUS = 0.1    # the HIP centre within this of the start begins a run (default)
END_RADIUS = 0.1      # ... within this of the target ends it (default)
CONTINUITY = 0.25     # progress along the path only counts in steps shorter than this (no short cuts)


def target_ring(radius: float = END_RADIUS) -> Mesh:
    """The red target hole: a flat ring around the path's end, drawn only."""
    import trimesh  # here, not at import: the loop process starts 0.4 s sooner without it
    ring = trimesh.creation.annulus(r_min=radius, r_max=radius + 0.04, height=0.02, sections=48)
    return Mesh.from_trimesh(ring)


class HotWire:
    id = "hot-wire-v1"
    title = "Hot wire (follow a path; vibration grows with the deviation)"
    PARAMS = (
        Param("path", "choice", "the path's shape", "segments", choices=PATH_KINDS),
        Param("points", "text", "a custom path for 'segments': \"x y z; x y z; ...\" in scene units (omit: the "
              "default zigzag)", None, optional=True),
        Param("threshold", "number", "allowed deviation without a cue (the difficulty)", HIP_RADIUS, 0.0, 0.5),
        Param("max_distance", "number", "beyond this deviation the cue stops", 0.3, 0.02, 2.0),
        Param("target_speed", "number", "moving-target variant: the target travels along the path at this "
              "speed (0: the classic hot wire)", 0.0, 0.0, 1.0, unit="units/s"),
        Param("height", "number", "the path's height above the table (default paths)", 0.5, 0.1, 2.0),
        Param("t_on_ms", "number", "PWM on time", 50.0, 5.0, 500.0, unit="ms"),
    )
    TRIAL_PARAMS = (
        Param("threshold", "number", "this trial's allowed deviation (omit: the scenario's)", None, 0.0, 0.5,
              optional=True),
    )
    CONTROLS = (
        Control("r", "back to the start (outside a trial: another run)"),
        Control("threshold", "change the allowed deviation (difficulty)", "operator",
                Param("threshold", "number", "allowed deviation without a cue", HIP_RADIUS, 0.0, 0.5)),
    )
    SUBTASKS = ()   # the thesis built this scene but left it out of its study (§4.2.4)
    REQUIRES = ()   # plain vibration

    def __init__(self, path: str = "segments", points: str | None = None, threshold: float = HIP_RADIUS,
                 max_distance: float = 0.3, target_speed: float = 0.0, height: float = 0.5,
                 t_on_ms: float = 50.0):
        if max_distance <= threshold:
            raise ValueError(f"max_distance ({max_distance}) must exceed threshold ({threshold})")
        self.path: Path = make_path(path, height, points)
        self.kind, self.threshold, self.max_distance = path, threshold, max_distance
        self.target_speed, self.t_on_ms = target_speed, t_on_ms
        self.reset(0)

    # -- scene ------------------------------------------------------------------------------
    def build_scene(self) -> Scene:
        green, red = Material("#2ca02c"), Material("#d62728")
        end = self.path.end
        objects = [
            SceneObject("table", Plane(TABLE), Pose(), Material("#8b6b4a")),
            SceneObject("wire", self.path.mesh(), Pose(), green, haptic=False),
            SceneObject("start", Sphere(0.05), Pose(self.path.start), Material("#98df8a"), haptic=False),
            SceneObject("target", target_ring(), Pose((end[0], end[1], end[2] - 0.01)), red, haptic=False),
            SceneObject("pacer", Sphere(0.05), Pose(self.path.start), red, haptic=False, visible=False),
        ]
        camera = Camera("perspective", position=(3.4, 0.0, 2.9), target=(0.0, 0.0, 0.3), up=(0.0, 0.0, 1.0),
                        fov_deg=45.0)
        return Scene("hot-wire", tuple(objects), camera, hud_text="Touch the start")

    # -- state ------------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self.trial: Trial | None = None
        self.allowed = self.threshold
        self.pending = Pending()
        self._last_t: float | None = None
        self._restart()

    def _restart(self) -> None:
        self.phase = "start"        # start → tracing → done
        self.t_start = self.t_done = None
        self.progress = 0.0         # arc length reached by continuous advance
        self.time_outside = 0.0
        self.hip_path = 0.0
        self.deviation_sum, self.deviation_max, self.lag_sum, self.samples = 0.0, 0.0, 0.0, 0
        self._last_hip = None
        self._pacer_shown = False

    def set_trial(self, trial: Trial | None) -> None:
        self.trial = trial
        self.allowed = trial.params["threshold"] if trial and trial.params["threshold"] is not None \
            else self.threshold
        self._restart()

    def on_input(self, key: str, action: str, value: Any = None) -> None:
        if action == "up":
            return
        if key == "r" and (self.trial is None or self.phase != "done"):
            self._restart()
            self.pending.emit("restart")
        elif key == "threshold":
            if float(value) >= self.max_distance:
                self.pending.emit("refused", key=key,
                                  reason=f"threshold must stay below max_distance {self.max_distance}")
                return
            self.allowed = float(value)
            self.pending.emit("threshold", threshold=self.allowed)

    # -- tick -------------------------------------------------------------------------------
    def step(self, ctx: TickContext) -> ScenarioOutput:
        dt = 0.0 if self._last_t is None else ctx.t_s - self._last_t
        self._last_t = ctx.t_s
        hip = ctx.hip
        on_path = self.path.project(hip)
        cues: tuple = ()
        values: dict[str, Any] = {"deviation": round(on_path.distance, 6), "threshold": self.allowed}
        if self.phase == "start" and math.dist(hip, self.path.start) <= START_RADIUS:
            self.phase, self.t_start = "tracing", ctx.t_s
            self._last_hip = hip
            self.pending.emit("start")
            dt = 0.0  # the run's clock starts now
        if self.phase == "tracing":
            deviation = on_path.distance
            if self.target_speed:
                pacer = self.path.point_at(self.target_speed * (ctx.t_s - self.t_start))
                self.pending.poses["pacer"] = Pose(pacer)
                lag = math.dist(hip, pacer)
                self.lag_sum += lag
                values["lag"] = round(lag, 6)
                deviation = lag  # the moving target, not the whole path, is what to follow
            self._track(ctx.t_s, dt, hip, on_path, deviation)
            if self.phase == "tracing":
                made = hot_wire_cue(deviation, self.allowed, self.max_distance, self.t_on_ms)
                cues = () if made is None else (made,)
        shown = self.phase == "tracing" and bool(self.target_speed)
        if shown != self._pacer_shown:
            self.pending.visible["pacer"] = self._pacer_shown = shown
        values["phase"] = self.phase
        values.update({k: v for k, v in self.metrics().items() if v is not None})
        return self.pending.flush(cues=cues, hud=self._hud(ctx), values=values)

    def _track(self, t: float, dt: float, hip, on_path, deviation: float) -> None:
        if deviation > self.allowed:
            self.time_outside += dt
        self.samples += 1
        self.deviation_sum += deviation
        self.deviation_max = max(self.deviation_max, deviation)
        self.hip_path += math.dist(self._last_hip, hip)
        self._last_hip = hip
        if on_path.distance <= self.max_distance and abs(on_path.arc - self.progress) <= CONTINUITY:
            self.progress = max(self.progress, on_path.arc)
        pacer_done = not self.target_speed or self.target_speed * (t - self.t_start) >= self.path.length
        if (self.progress >= self.path.length - END_RADIUS and math.dist(hip, self.path.end) <= END_RADIUS
                and pacer_done):
            self.phase, self.t_done = "done", t
            self.pending.finish(self.metrics())

    def metrics(self) -> dict:
        n = self.samples
        return {
            "completion_s": round(self.t_done - self.t_start, 6) if self.t_done is not None else None,
            "time_outside_s": round(self.time_outside, 6) if self.t_start is not None else None,
            "deviation_mean": round(self.deviation_sum / n, 9) if n else None,
            "deviation_max": round(self.deviation_max, 9) if n else None,
            "path_length": round(self.hip_path, 9) if self.t_start is not None else None,
            "progress": round(self.progress / self.path.length, 6),
            "lag_mean": round(self.lag_sum / n, 9) if n and self.target_speed else None,
        }

    def _hud(self, ctx: TickContext) -> str:
        if ctx.refusals:
            return "; ".join(ctx.refusals)
        prefix = f"{self.trial.title}: " if self.trial is not None else ""
        if self.phase == "start":
            return prefix + "Touch the start"
        if self.phase == "tracing":
            return prefix + ("Follow the red marker" if self.target_speed else "Follow the wire to the red hole")
        return prefix + ("Done" if self.trial is not None else "Done: press r to go again")
