"""Pick and place with two fingers: grasp a block between thumb and index and set it on a target
(a two-finger variant of object positioning, docs/scenarios.md; the thesis's future work asks for
several HIPs on several fingers).

Two tools, `right.index.tip` and `right.thumb.tip` (`fingers`), each its own god-object against
the scene. The block stays touchable all along, so both fingertips rest on its faces and feel it.
A grasp needs both:
- contact: both fingers' proxies touch the block, on roughly opposite sides (the directions from
  the block's centre to the two proxies at least 180° − `opposite_deg` apart);
- squeeze: both HIPs pressed into the block by at least `squeeze` (the HIP-to-proxy distance,
  the god-object's penetration).
Then the block follows the midpoint of the two fingers' HIPs (keeping the offset it had at the
grasp, so it does not jump) and never sinks into the table. The grasp holds while the grip stays
closed: the two HIPs at least `squeeze` closer together than the two proxies were at the grasp
(the two presses summed, half what the grasp needed: hysteresis, so a grasp at the threshold does
not chatter). The grip, not each finger's own press or contact, because the block follows the
fingers one tick late: a tracker sample that moves the hand fast takes the leading finger out of
the block for that tick (and its contact gate off) while the grip is unchanged; and a finger
cannot slide off a block that follows the fingers. It is released when the grip opens or a
finger's tracker is lost; then it drops onto the table. Released over the target (its centre within `tolerance` of the
target's, on the table plane) it is placed: the trial ends. Released anywhere else it is a drop,
and may be grasped again (beyond the table's edge it falls off and is put back at its start).

Cues: each finger touching the block gets a vibration on its own finger's devices (the primary
tool's in `cues`, the thumb's in `tool_cues`); while the grasp holds both get a stronger one, steady
through the ticks a fast sample takes a finger off the face (no extra device command).

Metrics (values, and at the placement `finished` with a `trial_done` event): time to grasp (trial
start → first grasp), time to place (first grasp → placement), placement error (the block's
centre to the target's, on the table), drops.
"""

from __future__ import annotations

import math
from types import MappingProxyType
from typing import Any

from server.core.cues import Vibration
from server.core.haptics.primitives import Box, Cylinder, Plane, Pose
from server.core.points import PRIMARY_POINT
from server.core.scenario import Control, Param, Pending, ScenarioOutput, SubTask, TickContext, Trial
from server.core.scene import Camera, Material, Scene, SceneObject

INDEX, THUMB = PRIMARY_POINT, "right.thumb.tip"
TABLE = (3.0, 4.0)              # depth (x) × width (y)
BLOCK = "block"
BLOCK_SIDE = 0.3
BLOCK_START = (0.0, 0.9)        # (x, y) on the table
TARGET = "target"
TARGET_RADIUS = 0.2             # the drawn pad
TARGET_AT = (0.0, -0.9)         # default target (x, y)
SQUEEZE = 0.02                  # scene units the HIPs must press into the block
RELEASE_FRACTION = 0.5          # the grasp holds while the grip keeps this part of the two presses
OPPOSITE_DEG = 45.0
TOLERANCE = 0.1
TOUCH_PCT, GRIP_PCT = 40.0, 100.0  # vibration while a finger touches the block / while it is held
THUMB_QUIET = MappingProxyType({THUMB: ()})  # no cue on the thumb's devices (shared: the loop compares by identity first)


def press_depth(tool) -> float:
    """How far a tool's HIP is pressed into what its proxy rests on (god-object penetration)."""
    return math.dist(tool.hip, tool.proxy)


def opposite_angle_deg(centre, a, b) -> float:
    """Angle between the directions from `centre` to `a` and to `b` (180: exactly opposite)."""
    u = [p - c for p, c in zip(a, centre)]
    v = [p - c for p, c in zip(b, centre)]
    nu, nv = math.hypot(*u), math.hypot(*v)
    if nu == 0.0 or nv == 0.0:
        return 0.0
    cos = sum(x * y for x, y in zip(u, v)) / (nu * nv)
    return math.degrees(math.acos(max(-1.0, min(1.0, cos))))


def needs_two_fingers(untracked: list[str]) -> str:
    """The HUD on a rig that does not track both fingers (docs/scenarios.md, pick-place-v1)."""
    return (f"Pick and place needs two tracked fingers ({INDEX}, {THUMB}); not tracked: {', '.join(untracked)}. "
            "A mouse moves one point only: use a hand tracker.")


def touches(tool, body: str) -> bool:
    """The tool is in (debounced) contact and its proxy touches `body`."""
    return tool.contact and not tool.lost and body in tool.touching


class PickPlace:
    id = "pick-place-v1"
    title = "Pick and place with two fingers (grasp between thumb and index)"
    fingers = (INDEX, THUMB)
    PARAMS = (
        Param("squeeze", "number", "grasp: both HIPs pressed into the block by at least this", SQUEEZE, 0.002, 0.2,
              unit="units"),
        Param("opposite_deg", "number", "grasp: the two contacts at most this far from opposite sides of the block",
              OPPOSITE_DEG, 5.0, 90.0, unit="deg"),
        Param("tolerance", "number", "placed: the block's centre within this of the target's (on the table)",
              TOLERANCE, 0.01, 0.5, unit="units"),
    )
    TRIAL_PARAMS = (
        Param("target_x", "number", "where the target is (depth)", TARGET_AT[0], -1.0, 1.0, unit="units"),
        Param("target_y", "number", "where the target is (across)", TARGET_AT[1], -1.6, 0.4, unit="units"),
    )
    CONTROLS = (Control(" ", "put the block back at its start (after a placement, outside trials)"),)
    SUBTASKS = (
        SubTask("place", "Pick and place: three targets", tuple({"target_x": x, "target_y": y} for x, y in (
            (0.0, -0.9), (-0.6, -0.5), (0.6, -1.3))), None, practice_trials=1),
    )
    REQUIRES = ()  # a contact vibration; a device that cannot show it says so in the HUD

    def __init__(self, squeeze: float = SQUEEZE, opposite_deg: float = OPPOSITE_DEG, tolerance: float = TOLERANCE):
        self.squeeze, self.opposite_deg, self.tolerance = squeeze, opposite_deg, tolerance
        self.reset(0)

    # -- scene ------------------------------------------------------------------------------
    def build_scene(self) -> Scene:
        half = BLOCK_SIDE / 2
        objects = (
            SceneObject("table", Plane(TABLE), Pose(), Material("#8b6b4a")),
            SceneObject(TARGET, Cylinder(TARGET_RADIUS, 0.004), Pose((*TARGET_AT, 0.0)), Material("#2ca02c"),
                        haptic=False),
            SceneObject(BLOCK, Box((BLOCK_SIDE,) * 3), Pose((*BLOCK_START, half)), Material("#1f77b4")),
        )
        # from the front and above: the fingers close across y, which this view shows
        camera = Camera("perspective", position=(2.5, 0.0, 1.6), target=(0.0, 0.0, 0.15), up=(0.0, 0.0, 1.0))
        return Scene("pick_place", objects, camera, hud_text="Grasp the block between thumb and index")

    # -- state ------------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self.trial: Trial | None = None
        self.target = TARGET_AT
        self.pending = Pending()
        self._begin()

    def _begin(self) -> None:
        """The block back at its start, nothing held, the clocks and counts of a trial at zero."""
        self.phase = "idle"          # idle → held → (idle after a drop) → placed
        self.centre = (*BLOCK_START, BLOCK_SIDE / 2)
        self.offset = (0.0, 0.0, 0.0)  # block centre − fingers' midpoint, fixed at the grasp
        self.rest_width = 0.0          # the two proxies' distance at the grasp: the grip's width at rest
        self.t_start = self.t_grasp = self.t_placed = None
        self.drops = 0
        self.error: float | None = None
        self.pending.poses[BLOCK] = Pose(self.centre)

    def set_trial(self, trial: Trial | None) -> None:
        self.trial = trial
        self.target = (trial.params["target_x"], trial.params["target_y"]) if trial else TARGET_AT
        self.pending.poses[TARGET] = Pose((*self.target, 0.0))
        self._begin()

    def on_input(self, key: str, action: str, value: Any = None) -> None:
        if key == " " and action != "up" and self.phase == "placed" and self.trial is None:
            self._begin()

    # -- tick -------------------------------------------------------------------------------
    def step(self, ctx: TickContext) -> ScenarioOutput:
        if self.t_start is None:
            self.t_start = ctx.t_s
        tools = {t.name: t for t in ctx.tools}
        index, thumb = tools.get(INDEX), tools.get(THUMB)
        # The thumb's tool exists on every rig (the scenario declares it), but a one-point rig (a
        # mouse, a single tracked point) never drives it: it rests at home. Say so, as the grasp
        # cannot happen; a held block is still released below when the thumb's tracker goes.
        untracked = [n for n, t in ((INDEX, index), (THUMB, thumb)) if t is None or (n != INDEX and not t.driven)]
        if untracked and not (self.phase == "held" and index is not None and thumb is not None):
            quiet = THUMB_QUIET if thumb is not None else {}  # the thumb's device: nothing stays on
            return self.pending.flush(hud=needs_two_fingers(untracked), tool_cues=quiet,
                                      values={"phase": self.phase, "missing": untracked})
        if self.phase == "idle" and self._grasps(index, thumb):
            self._grasp(ctx.t_s, index, thumb)
        elif self.phase == "held":
            if self._holds(index, thumb):
                self._carry(index, thumb)
            else:
                self._release(ctx.t_s, "tracking_lost" if index.lost or thumb.lost else "opened")
        held = self.phase == "held"
        if held:
            cues_of = dict.fromkeys((INDEX, THUMB), (Vibration(GRIP_PCT),))
        else:
            cues_of = {t.name: (Vibration(TOUCH_PCT),) if touches(t, BLOCK) else () for t in (index, thumb)}
        return self.pending.flush(cues=cues_of[INDEX], tool_cues={THUMB: cues_of[THUMB]}, hud=self._hud(ctx),
                                  values=self._values(index, thumb), held=BLOCK if held else None)

    def _grasps(self, index, thumb) -> bool:
        return (touches(index, BLOCK) and touches(thumb, BLOCK)
                and press_depth(index) >= self.squeeze and press_depth(thumb) >= self.squeeze
                and opposite_angle_deg(self.centre, index.proxy, thumb.proxy) >= 180.0 - self.opposite_deg)

    def grip(self, index, thumb) -> float:
        """How far the grip is closed: the two HIPs' distance below the grasp's resting width."""
        return self.rest_width - math.dist(index.hip, thumb.hip)

    def _holds(self, index, thumb) -> bool:
        tracked = not (index.lost or thumb.lost)
        return tracked and self.grip(index, thumb) >= RELEASE_FRACTION * 2 * self.squeeze

    @staticmethod
    def _midpoint(index, thumb) -> tuple[float, float, float]:
        return tuple((a + b) / 2 for a, b in zip(index.hip, thumb.hip))

    def _grasp(self, t: float, index, thumb) -> None:
        self.phase = "held"
        mid = self._midpoint(index, thumb)
        self.offset = tuple(c - m for c, m in zip(self.centre, mid))
        self.rest_width = math.dist(index.proxy, thumb.proxy)
        if self.t_grasp is None:
            self.t_grasp = t
        self.pending.emit("grasp", press_index=round(press_depth(index), 6), press_thumb=round(press_depth(thumb), 6))

    def _carry(self, index, thumb) -> None:
        x, y, z = (m + o for m, o in zip(self._midpoint(index, thumb), self.offset))
        self.centre = (x, y, max(BLOCK_SIDE / 2, z))  # never into the table
        self.pending.poses[BLOCK] = Pose(self.centre)

    def _release(self, t: float, reason: str) -> None:
        """Let go: the block drops onto the table; over the target it is placed, elsewhere dropped
        (off the table's edge it falls and is put back at its start)."""
        x, y, _ = self.centre
        error = math.dist((x, y), self.target)
        on_table = abs(x) <= TABLE[0] / 2 and abs(y) <= TABLE[1] / 2
        self.centre = (x, y, BLOCK_SIDE / 2) if on_table else (*BLOCK_START, BLOCK_SIDE / 2)
        self.pending.poses[BLOCK] = Pose(self.centre)
        if error <= self.tolerance:
            self.phase, self.t_placed, self.error = "placed", t, error
            self.pending.emit("place", error=round(error, 9), reason=reason)
            if self.trial is not None:
                self.pending.finish(self.metrics())
        else:
            self.phase = "idle"
            self.drops += 1
            self.pending.emit("drop", error=round(error, 9), reason=reason, off_table=not on_table)

    def metrics(self) -> dict:
        return {
            "time_to_grasp_s": round(self.t_grasp - self.t_start, 6) if self.t_grasp is not None else None,
            "time_to_place_s": round(self.t_placed - self.t_grasp, 6) if self.t_placed is not None else None,
            "placement_error": round(self.error, 9) if self.error is not None else None,
            "drops": self.drops,
        }

    def _values(self, index, thumb) -> dict:
        values: dict[str, Any] = {"phase": self.phase, "press_index": round(press_depth(index), 6),
                                  "press_thumb": round(press_depth(thumb), 6),
                                  **({"grip": round(self.grip(index, thumb), 6)} if self.phase == "held" else {}),
                                  "distance": round(math.dist(self.centre[:2], self.target), 6)}
        if touches(index, BLOCK) and touches(thumb, BLOCK):
            values["opposite_deg"] = round(opposite_angle_deg(self.centre, index.proxy, thumb.proxy), 3)
        values.update({k: v for k, v in self.metrics().items() if v is not None})
        return values

    def _hud(self, ctx: TickContext) -> str:
        if ctx.refusals:
            return "; ".join(ctx.refusals)
        if self.phase == "held":
            return "Place it on the green target"
        if self.phase == "placed":
            return "Done" if self.trial is not None else "Placed: press space for another go"
        return "Grasp the block between thumb and index"
