"""Scenario 7, peg-in-hole (thesis §4.2.4; docs/scenarios.md).

The positioning task's table, objects and holes (scenarios/positioning.py), seen through a
perspective camera that the participant may orbit and zoom (all three dimensions visible).
Touching an object grasps it (it hangs below the fingertip, orientation fixed). Every tick the
nearest hole (least Euclidean distance, among the holes still free) is chosen again, and the cue
follows the distance to it: intensity and pulse rate rise linearly as the object nears the hole,
nothing beyond the boundary; in reverse mode they fall toward the hole and stop at it
(scenarios/guidance.peg_cue).

A hole's centre, for that distance, is where the carried object's centre is when the object sits
in the hole with its top level with the rim: exactly where it is when the fingertip rests on the
rim's centre. An object that fits inside a hole (a cube needs 1.5× scaled holes to fit a round
one) drops in and stays; that completes the trial.

Metrics (values, and at the insertion `finished` with a `trial_done` event): completion time
(pick → insertion), the object's trajectory length, the hole it went into and whether that was
its own.
"""

from __future__ import annotations

import math
from typing import Any

from server.core.scenario import Control, Param, Pending, ScenarioOutput, TickContext, Trial, in_contact_with
from scenarios.guidance import BOUNDARY, TARGET_THRESHOLD, peg_cue
from scenarios.positioning import ITEM_IDS, ITEMS, Item, carried_position, inserted, table_objects
from server.core.haptics.primitives import Pose
from server.core.scene import Camera, Scene

from server.core.tool import DEFAULT_PROXY_RADIUS as PROXY_RADIUS


def hole_centre(item: Item, carried: Item) -> tuple[float, float, float]:
    """Where `carried` is centred when it sits in `item`'s hole, its top level with the rim."""
    x, y = item.hole_at
    return x, y, item.hole.height - carried.half


class PegInHole:
    id = "peg-in-hole-v1"
    title = "Peg-in-hole (perspective view; cue toward the nearest hole)"
    PARAMS = (
        Param("boundary", "number", "no cue farther than this from the nearest hole", BOUNDARY, 0.1, 5.0),
        Param("reverse", "bool", "reverse mode: the cue falls toward the hole and stops at it", False),
        Param("threshold", "number", "reverse mode: no cue within this of the hole", TARGET_THRESHOLD, 0.005, 0.5),
        Param("t_on_ms", "number", "PWM on time", 50.0, 5.0, 500.0, unit="ms"),
    )
    TRIAL_PARAMS = (
        Param("object", "choice", "the object to put into a hole", None, choices=ITEM_IDS),
        Param("reverse", "bool", "this trial's cue direction (omit: the scenario's)", None, optional=True),
    )
    CONTROLS = (
        Control("r", "put every object back on the table (outside a trial)"),
        Control("hole_scale", "scale every hole (difficulty: a larger acceptance zone)", "operator",
                Param("scale", "number", "factor on the holes' inner and outer size", 1.0, 0.5, 2.0)),
    )
    SUBTASKS = ()   # the thesis built this scene but left it out of its study (§4.2.4)
    REQUIRES = ()   # plain vibration

    def __init__(self, boundary: float = BOUNDARY, reverse: bool = False, threshold: float = TARGET_THRESHOLD,
                 t_on_ms: float = 50.0):
        self.boundary, self.reverse, self.threshold, self.t_on_ms = boundary, reverse, threshold, t_on_ms
        self.reset(0)

    def build_scene(self) -> Scene:
        camera = Camera("perspective", position=(5.0, 0.0, 3.0), target=(0.0, 0.0, 0.3), up=(0.0, 0.0, 1.0),
                        fov_deg=45.0)
        return Scene("peg-in-hole", tuple(table_objects()), camera, hud_text="Pick up an object")

    # -- state ------------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self.trial: Trial | None = None
        self.scale = 1.0
        self.pending = Pending()
        self._clear_table()

    def _clear_table(self) -> None:
        """Every object back at its start, touchable; nothing carried or placed."""
        self.pending.poses = {item.id: Pose((*item.start, item.half)) for item in ITEMS}
        self.pending.touchable = {item.id: True for item in ITEMS}
        self.placed: dict[str, str] = {}   # object id → the object id whose hole it is in
        self.carried: Item | None = None
        self.position = None
        self.nearest: Item | None = None
        self.distance: float | None = None
        self.t_pick = self.t_done = None
        self.path_length = 0.0
        self.last: dict[str, Any] = {}     # the latest insertion's metrics

    def _reverse(self) -> bool:
        if self.trial is not None and self.trial.params["reverse"] is not None:
            return self.trial.params["reverse"]
        return self.reverse

    def set_trial(self, trial: Trial | None) -> None:
        self.trial = trial
        self._clear_table()

    def on_input(self, key: str, action: str, value: Any = None) -> None:
        if action == "up":
            return
        if key == "r" and self.trial is None:
            self._clear_table()
            self.pending.emit("clear")
        elif key == "hole_scale":
            self.scale = float(value)
            self.pending.emit("hole_scale", scale=self.scale)
            self.pending.scales.update({f"{item.id}_hole": (self.scale, self.scale, 1.0) for item in ITEMS})

    # -- tick -------------------------------------------------------------------------------
    def step(self, ctx: TickContext) -> ScenarioOutput:
        cues: tuple = ()
        if self.carried is None:
            touched = in_contact_with(ctx, self._graspable())
            if touched is not None:
                self._grasp(ctx.t_s, ITEMS[ITEM_IDS.index(touched)])
        if self.carried is not None:
            item = self.carried
            position = carried_position(item, ctx.proxy, PROXY_RADIUS)
            if self.position is not None:
                self.path_length += math.dist(self.position, position)
            self.position = position
            self.pending.poses[item.id] = Pose(position)
            self._choose_nearest(item, position)
            hole = self._fitting_hole(item, position)
            if hole is not None:
                self._insert(ctx.t_s, item, hole)
            elif self.nearest is not None:
                made = peg_cue(self.distance, self.boundary, self._reverse(), self.threshold, self.t_on_ms)
                cues = () if made is None else (made,)
        return self.pending.flush(cues=cues, hud=self._hud(ctx), values=self._values(),
                                  held=None if self.carried is None else self.carried.id)

    def _graspable(self) -> tuple[str, ...]:
        if self.trial is not None:
            wanted = self.trial.params["object"]
            return () if wanted in self.placed else (wanted,)
        return tuple(i for i in ITEM_IDS if i not in self.placed)

    def _free_holes(self) -> list[Item]:
        taken = set(self.placed.values())
        return [i for i in ITEMS if i.id not in taken]

    def _grasp(self, t: float, item: Item) -> None:
        self.carried, self.t_pick, self.t_done = item, t, None
        self.position, self.path_length, self.nearest = None, 0.0, None
        self.pending.touchable[item.id] = False
        self.pending.emit("pick", object=item.id)

    def _choose_nearest(self, item: Item, position) -> None:
        """The free hole with the least Euclidean distance, chosen again every tick."""
        holes = self._free_holes()
        best = min(holes, key=lambda h: math.dist(position, hole_centre(h, item)), default=None)
        if best is not self.nearest:
            self.pending.emit("nearest_hole", hole=None if best is None else best.id)
        self.nearest = best
        self.distance = None if best is None else math.dist(position, hole_centre(best, item))

    def _fitting_hole(self, item: Item, position) -> Item | None:
        return next((h for h in self._free_holes()
                     if inserted(item, position, h.hole_at, self.scale, hole=h.hole)), None)

    def _insert(self, t: float, item: Item, hole: Item) -> None:
        self.placed[item.id] = hole.id
        self.carried, self.t_done = None, t
        self.pending.poses[item.id] = Pose((*hole.hole_at, item.half))  # it drops to the bottom of the tube
        self.last = {"object": item.id, "hole": hole.id, "own_hole": hole.id == item.id,
                     "completion_s": round(t - self.t_pick, 6), "path_length": round(self.path_length, 9)}
        self.pending.finish(self.last)
        self.position = self.nearest = self.distance = None

    def _values(self) -> dict:
        values: dict[str, Any] = {"carried": None if self.carried is None else self.carried.id,
                                  "placed": len(self.placed), "reverse": self._reverse()}
        if self.nearest is not None:
            values["nearest_hole"] = self.nearest.id
            values["distance"] = round(self.distance, 6)
        if self.carried is not None:
            values["path_length"] = round(self.path_length, 9)
        values.update({f"last_{k}": v for k, v in self.last.items()})
        return values

    def _hud(self, ctx: TickContext) -> str:
        if ctx.refusals:
            return "; ".join(ctx.refusals)
        prefix = f"{self.trial.title}: " if self.trial is not None else ""
        if self.carried is not None:
            return prefix + "Put it into a hole"
        if self.trial is not None:
            return prefix + ("Done" if self.trial.params["object"] in self.placed else "Pick up the object")
        if len(self.placed) == len(ITEMS):
            return "All placed: press r to start again"
        return "Pick up an object"
