"""Scenario 6, object positioning (thesis §4.2, §5.5; docs/scenarios.md).

A table (3 deep × 4 wide, four legs 5 high, drawn only) with two cubes (side 0.3) and a sphere
(r 0.15), and a hole for each: square tubes (inner 0.3, outer 0.4, 0.5 high) and a round tube
(inner r 0.15, outer r 0.2, 0.4 high). The orthographic side view at table level hides depth (x),
so depth comes from touch. The tubes are trimesh meshes, drawn only; what the HIP touches is a
solid primitive of the same outer size (the task never needs the inside of a tube: the carried
object hangs below the fingertip and enters the tube while the fingertip rests on its rim).

One object at a time (`space` → the next): touching it grasps it (it hangs below the proxy,
orientation fixed, no longer touchable), an arrow appears over its target (above its hole), the
cue law of the condition guides depth (scenarios/guidance.py: vibration modes, patterns P1-P4,
the FerroVibe's 3-DoF guidance). Holding the object at the target (every axis within 0.05) for
2 s shows "GO"; then lowering it into its hole completes the trial. Holes may move (0.01/s) and
can be scaled by the experimenter.

Metrics (values, and at the insertion `finished` with a `trial_done` event): completion time
(pick → insertion), time to first reach the target, the object's trajectory length from pick to
insertion, the mean end-point error (3-D and depth) over the 2 s hold that led to GO.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any


from server.core.scenario import Control, Param, Pending, ScenarioOutput, SubTask, TickContext, Trial, in_contact_with
from scenarios.guidance import (BOUNDARY, MODES, PATTERNS, TARGET_THRESHOLD, PatternGuide, guidance_cues, mode_t_off,
                                pulse_cue)
from server.core.haptics.primitives import Box, Cone, Cylinder, Plane, Pose, Sphere
from server.core.scene import Camera, Material, Mesh, Scene, SceneObject
from server.core.tool import DEFAULT_PROXY_RADIUS

TABLE = (3.0, 4.0)            # depth (x) × width (y)
LEG_HEIGHT, LEG_RADIUS = 5.0, 0.05
HOLD_S = 2.0
TARGET_CLEARANCE = 0.3        # target height above the hole's rim (default)
CUES = ("none", *MODES, *PATTERNS, "3dof")
DOWN = (0.0, 1.0, 0.0, 0.0)   # quaternion: 180° about x, turns a +z cone into an arrow head pointing down


@dataclass(frozen=True)
class Hole:
    kind: str             # "square" | "round"
    inner: float          # inner half-size (square) or inner radius (round)
    outer: float
    height: float


@dataclass(frozen=True)
class Item:
    id: str
    half: float           # half the cube side, or the sphere radius
    start: tuple[float, float]   # (x, y) on the table
    hole: Hole
    hole_at: tuple[float, float]


SQUARE = Hole("square", 0.15, 0.2, 0.5)
ROUND = Hole("round", 0.15, 0.2, 0.4)
ITEMS = (  # objects on the right, holes on the left, each at its own depth
    Item("cube_a", 0.15, (-0.8, 1.8), SQUARE, (0.9, -1.6)),
    Item("sphere", 0.15, (0.2, 1.4), ROUND, (-0.7, -0.9)),
    Item("cube_b", 0.15, (0.9, 1.0), SQUARE, (0.2, -0.2)),
)
ITEM_IDS = tuple(i.id for i in ITEMS)


@functools.lru_cache(maxsize=16)  # a Mesh is frozen: every scene built (a switch per trial) shares it
def tube_mesh(hole: Hole, scale: float = 1.0) -> Mesh:
    """The hollow tube as a display mesh, base at z = 0 (trimesh: an annulus, or four wall boxes)."""
    import trimesh  # here, not at import: the loop process starts 0.4 s sooner without it
    inner, outer, h = hole.inner * scale, hole.outer * scale, hole.height
    if hole.kind == "round":
        mesh = trimesh.creation.annulus(r_min=inner, r_max=outer, height=h, sections=48)
    else:
        wall = outer - inner
        walls = [trimesh.creation.box((2 * outer, wall, h)).apply_translation((0, sy * (inner + wall / 2), 0))
                 for sy in (-1, 1)]
        walls += [trimesh.creation.box((wall, 2 * inner, h)).apply_translation((sx * (inner + wall / 2), 0, 0))
                  for sx in (-1, 1)]
        mesh = trimesh.util.concatenate(walls)
    mesh.apply_translation((0, 0, h / 2))
    return Mesh.from_trimesh(mesh)


def footprint(item: Item, hole_kind: str) -> float:
    """How far the object reaches from its centre across a hole of `hole_kind`: a cube's corners
    (orientation fixed, axis-aligned) reach half·√2 into a round hole, its faces half into a
    square one; a sphere reaches its radius either way."""
    is_cube = item.id != "sphere"
    return item.half * math.sqrt(2.0) if is_cube and hole_kind == "round" else item.half


def inserted(item: Item, pos, hole_xy, scale: float, tolerance: float = TARGET_THRESHOLD,
             hole: Hole | None = None) -> bool:
    """The object is inside a hole (its own unless `hole` is given): within the (scaled) inner
    wall up to `tolerance`, below the rim and not below the table."""
    hole = hole or item.hole
    dx, dy = pos[0] - hole_xy[0], pos[1] - hole_xy[1]
    room = hole.inner * scale - footprint(item, hole.kind) + tolerance
    inside = math.hypot(dx, dy) <= room if hole.kind == "round" else max(abs(dx), abs(dy)) <= room
    bottom = pos[2] - item.half
    return inside and -1e-9 <= bottom and bottom + 2 * item.half <= hole.height + tolerance


COLOURS = {"cube_a": "#d62728", "sphere": "#2ca02c", "cube_b": "#1f77b4"}


def rim_pose(item: Item, hole_xy) -> Pose:
    """Where the touched solid of a hole sits (a box is centred, a cylinder stands on its base)."""
    return Pose((*hole_xy, 0.0 if item.hole.kind == "round" else item.hole.height / 2))


def table_objects() -> list[SceneObject]:
    """The table with its legs, the three objects at their starts and their holes: each hole a
    drawn tube mesh (`<id>_hole`) and an invisible solid of its outer size that the HIP touches
    (`<id>_rim`). Shared by the positioning and peg-in-hole scenes."""
    wood, steel = Material("#8b6b4a"), Material("#9aa3ad")
    objects = [SceneObject("table", Plane(TABLE), Pose(), wood)]
    for i, (sx, sy) in enumerate(((-1, -1), (-1, 1), (1, -1), (1, 1))):
        objects.append(SceneObject(f"leg_{i}", Cylinder(LEG_RADIUS, LEG_HEIGHT),
                                   Pose((sx * (TABLE[0] / 2 - 0.1), sy * (TABLE[1] / 2 - 0.1), -LEG_HEIGHT)),
                                   wood, haptic=False))
    for item in ITEMS:
        shape = Sphere(item.half) if item.id == "sphere" else Box((2 * item.half,) * 3)
        objects.append(SceneObject(item.id, shape, Pose((*item.start, item.half)), Material(COLOURS[item.id])))
        hole = item.hole
        solid = Cylinder(hole.outer, hole.height) if hole.kind == "round" else \
            Box((2 * hole.outer, 2 * hole.outer, hole.height))
        objects.append(SceneObject(f"{item.id}_hole", tube_mesh(hole), Pose((*item.hole_at, 0.0)), steel,
                                   haptic=False))
        objects.append(SceneObject(f"{item.id}_rim", solid, rim_pose(item, item.hole_at), steel, visible=False))
    return objects


def carried_position(item: Item, proxy, proxy_radius: float = DEFAULT_PROXY_RADIUS) -> tuple[float, float, float]:
    """A grasped object hangs below the fingertip, its top touching the proxy sphere (orientation
    fixed), and never sinks into the table."""
    return proxy[0], proxy[1], max(item.half, proxy[2] - item.half - proxy_radius)


class Positioning:
    id = "positioning-v1"
    title = "Object positioning (depth by touch; modes, patterns, 3-DoF guidance)"
    PARAMS = (
        Param("cue", "choice", "the guidance law: no cue, a vibration mode, a pattern, or the FerroVibe's 3-DoF "
              "guidance", "P1", choices=CUES),
        Param("p2_form", "choice", "P2/P4 curve: A (sine fit) or B (piecewise linear, the study's)", "B",
              choices=("A", "B")),
        Param("boundary", "number", "cue zone radius around the target", BOUNDARY, 0.1, 5.0),
        Param("threshold", "number", "'at target': within this on every axis", TARGET_THRESHOLD, 0.005, 0.5),
        Param("t_on_ms", "number", "PWM on time", 50.0, 5.0, 500.0, unit="ms"),
        Param("hole_speed", "number", "holes move along y at this speed, back and forth (0.01 in the thesis's "
              "dynamic variant)", 0.0, 0.0, 0.5, unit="units/s"),
        Param("hold_s", "number", "how long the object must stay at the target before GO", HOLD_S, 0.0, 30.0,
              unit="s"),
    )
    TRIAL_PARAMS = (
        Param("object", "choice", "the object to position", None, choices=ITEM_IDS),
        Param("cue", "choice", "this trial's guidance law (omit: the scenario's)", None, choices=CUES,
              optional=True),
    )
    CONTROLS = (
        Control(" ", "next object (after an insertion)"),
        Control("hole_scale", "scale every hole (difficulty: a larger acceptance zone)", "operator",
                Param("scale", "number", "factor on the holes' inner and outer size", 1.0, 0.5, 2.0)),
    )
    SUBTASKS = (
        SubTask("patterns", "FingerTac: three patterns × three targets (thesis §5.5)",
                tuple({"object": o, "cue": c} for c in ("P1", "P2", "P3") for o in ITEM_IDS),
                Param("helpfulness", "int", "How much did the vibration pattern aid in achieving the task?", None, 1,
                      7, labels={1: "not at all", 7: "very helpful"}),
                practice_trials=2, question="How much did the vibration pattern aid in achieving the task?"),
        SubTask("modes", "FingerTac: the two vibration modes (order counterbalanced)",
                tuple({"object": "cube_a", "cue": m} for m in MODES), None, practice_trials=1),
        SubTask("ferrovibe", "FerroVibe: 3-DoF guidance, three targets",
                tuple({"object": o, "cue": "3dof"} for o in ITEM_IDS),
                Param("helpfulness", "int", "How much did the tactile cues aid in achieving the task?", None, 1, 7,
                      labels={1: "not at all", 7: "very helpful"}),
                practice_trials=1),
    )
    REQUIRES = ()  # guidance is plain vibration (and tilt for 3dof): a device that cannot, says so in the HUD

    def __init__(self, cue: str = "P1", p2_form: str = "B", boundary: float = BOUNDARY,
                 threshold: float = TARGET_THRESHOLD, t_on_ms: float = 50.0, hole_speed: float = 0.0,
                 hold_s: float = HOLD_S):
        self.cue, self.p2_form, self.boundary, self.threshold = cue, p2_form, boundary, threshold
        self.t_on_ms, self.hole_speed, self.hold_s = t_on_ms, hole_speed, hold_s
        self.reset(0)

    # -- scene ------------------------------------------------------------------------------
    def build_scene(self) -> Scene:
        objects = table_objects()
        objects.append(SceneObject("arrow_shaft", Cylinder(0.015, 0.35), Pose((0.0, 0.0, 5.0)), Material("#ffd400"),
                                   haptic=False, visible=False))
        objects.append(SceneObject("arrow_head", Cone(0.05, 0.12), Pose((0.0, 0.0, 5.0), DOWN), Material("#ffd400"),
                                   haptic=False, visible=False))
        # orthographic, at table level, from the front: depth (x) cannot be seen; no shadows in any client
        camera = Camera("orthographic", position=(6.0, 0.0, 0.6), target=(0.0, 0.0, 0.6), up=(0.0, 0.0, 1.0),
                        height=3.2)
        return Scene("positioning", tuple(objects), camera, hud_text="Pick up the object")

    # -- state ------------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self.trial: Trial | None = None
        self.index = 0              # the active item outside trials
        self.scale = 1.0
        self.hole_offset = 0.0      # moving holes: displacement along y
        self.hole_dir = 1.0
        self._last_t: float | None = None
        self.pending = Pending()
        self._arrow_at: tuple | None = None  # where the last output put the arrow (_place_arrow)
        self._target_memo: tuple = (None, None, None)  # (item, hole offset, target): target()
        self._last_cues: tuple = (None, ())  # (t_off, cues) of the last pulse law cue: _cues()
        self._begin(self.index)

    def _begin(self, index: int) -> None:
        """Make item `index` the active one, back at its start, ungrasped."""
        self.index = index
        self.phase = "idle"       # idle → carry → go → inserted
        self.position = None
        self.t_pick = self.t_first_target = self.t_go = self.t_done = None
        self.hold_since: float | None = None
        # the hold's errors as running sums, not a list summed every tick (that was O(hold²): a
        # fifth of a simulated study's time); summed in the same order, so the same numbers
        self.hold_n, self.hold_error_sum, self.hold_depth_error_sum = 0, 0.0, 0.0
        self.path_length = 0.0      # of the object, pick → insertion (kept as a running sum: O(1) per tick)
        self.guide = PatternGuide(self._cue(), self.p2_form, self.boundary) if self._cue() in PATTERNS else None
        item = ITEMS[index]
        self.pending.poses[item.id] = Pose((*item.start, item.half))
        self.pending.touchable[item.id] = True
        self.pending.visible.update({"arrow_shaft": False, "arrow_head": False})

    def _cue(self) -> str:
        if self.trial is not None and self.trial.params["cue"] is not None:
            return self.trial.params["cue"]
        return self.cue

    def set_trial(self, trial: Trial | None) -> None:
        """Every trial starts from a clean table: all objects back at their starts, touchable."""
        self.trial = trial
        for item in ITEMS:
            self.pending.poses[item.id] = Pose((*item.start, item.half))
            self.pending.touchable[item.id] = True
        self._begin(ITEM_IDS.index(trial.params["object"]) if trial else 0)

    def on_input(self, key: str, action: str, value: Any = None) -> None:
        if action == "up":
            return
        if key == " " and self.phase == "inserted" and self.trial is None:
            self._begin((self.index + 1) % len(ITEMS))
        elif key == "hole_scale":
            self.scale = float(value)
            self.pending.emit("hole_scale", scale=self.scale)
            # the tubes widen (not taller); the rims the fingertip rests on keep their size
            self.pending.scales.update({f"{item.id}_hole": (self.scale, self.scale, 1.0) for item in ITEMS})

    def hole_xy(self, item: Item) -> tuple[float, float]:
        return item.hole_at[0], item.hole_at[1] + self.hole_offset

    def target(self, item: Item) -> tuple[float, float, float]:
        memo = self._target_memo  # the same until the item or the holes move: the same tuple every tick
        if memo[0] is item and memo[1] == self.hole_offset:
            return memo[2]
        x, y = self.hole_xy(item)
        target = x, y, round(item.hole.height + TARGET_CLEARANCE + item.half, 9)
        self._target_memo = (item, self.hole_offset, target)
        return target

    # -- tick -------------------------------------------------------------------------------
    def step(self, ctx: TickContext) -> ScenarioOutput:
        dt = 0.0 if self._last_t is None else ctx.t_s - self._last_t
        self._last_t = ctx.t_s
        item = ITEMS[self.index]
        if self.hole_speed:
            self._move_holes(dt)
        target = self.target(item)
        cues: tuple = ()
        if self.phase == "idle" and in_contact_with(ctx, (item.id,)):
            self._grasp(ctx, item)
        if self.phase in ("carry", "go"):
            position = carried_position(item, ctx.proxy)
            if self.position is not None:
                self.path_length += math.dist(self.position, position)
            self.position = position
            self.pending.poses[item.id] = Pose(self.position)
            threshold = self.threshold
            at = (abs(position[0] - target[0]) <= threshold and abs(position[1] - target[1]) <= threshold
                  and abs(position[2] - target[2]) <= threshold)
            self._track_target(ctx.t_s, self.position, target, at)
            if self.phase == "go" and inserted(item, self.position, self.hole_xy(item), self.scale):
                self._insert(ctx.t_s, item)
            else:
                cues = self._cues(self.position, target, at)
        if self.pending.visible.get("arrow_shaft") or self.phase in ("carry", "go"):
            self._place_arrow(target)
        return self.pending.flush(cues=cues, hud=self._hud(ctx), values=self._values(target) if ctx.drawn else None,
                                  held=item.id if self.phase in ("carry", "go") else None)

    def _grasp(self, ctx: TickContext, item: Item) -> None:
        self.phase, self.t_pick = "carry", ctx.t_s
        self.pending.touchable[item.id] = False
        self.pending.visible.update({"arrow_shaft": True, "arrow_head": True})
        self.pending.emit("pick", object=item.id)

    def _track_target(self, t: float, pos, target, at: bool) -> None:
        if at and self.t_first_target is None:
            self.t_first_target = t
            self.pending.emit("reached", object=ITEMS[self.index].id)
        if self.phase != "carry":
            return
        if not at:
            self.hold_since = None
            self.hold_n, self.hold_error_sum, self.hold_depth_error_sum = 0, 0.0, 0.0
            return
        if self.hold_since is None:
            self.hold_since = t
        self.hold_n += 1
        self.hold_error_sum += math.dist(pos, target)
        self.hold_depth_error_sum += abs(pos[0] - target[0])
        if t - self.hold_since >= self.hold_s:
            self.phase, self.t_go = "go", t
            self.pending.emit("go", object=ITEMS[self.index].id)

    def _insert(self, t: float, item: Item) -> None:
        self.phase, self.t_done = "inserted", t
        self.pending.visible.update({"arrow_shaft": False, "arrow_head": False})
        self.pending.finish({"object": item.id, **self.metrics()})

    def metrics(self) -> dict:
        done = self.t_done is not None
        n = self.hold_n
        return {
            "completion_s": round(self.t_done - self.t_pick, 6) if done else None,
            "time_to_target_s": round(self.t_first_target - self.t_pick, 6) if self.t_first_target is not None
            else None,
            "path_length": round(self.path_length, 9),
            "hold_error_mean": round(self.hold_error_sum / n, 9) if n else None,
            "hold_depth_error_mean": round(self.hold_depth_error_sum / n, 9) if n else None,
        }

    def _cues(self, pos, target, at: bool) -> tuple:
        cue = self._cue()
        if cue == "none":
            return ()
        if cue == "3dof":
            return guidance_cues(pos, target, threshold=self.threshold, boundary=self.boundary, t_on_ms=self.t_on_ms)
        depth = abs(pos[0] - target[0])
        in_zone = math.dist(pos, target) <= self.boundary
        if cue in MODES:
            t_off = mode_t_off(cue, depth, in_zone, self.boundary, self.threshold)
        else:
            t_off = self.guide.t_off(depth, in_zone, at)
        if t_off == self._last_cues[0] and t_off is not None:
            return self._last_cues[1]  # the law's value unchanged: the same tuple, a no-change the loop sees by identity
        made = pulse_cue(t_off, self.t_on_ms)
        cues = (made,) if made is not None else ()
        self._last_cues = (t_off, cues)
        return cues

    def _move_holes(self, dt: float) -> None:
        self.hole_offset += self.hole_dir * self.hole_speed * dt
        if abs(self.hole_offset) > 0.3:  # back and forth within ±0.3 of the home positions
            self.hole_dir = -self.hole_dir
            self.hole_offset = math.copysign(0.3, self.hole_offset)
        for item in ITEMS:
            x, y = self.hole_xy(item)
            self.pending.poses[f"{item.id}_hole"] = Pose((x, y, 0.0))
            self.pending.poses[f"{item.id}_rim"] = rim_pose(item, (x, y))

    def _place_arrow(self, target) -> None:
        x, y, z = target
        top = z + ITEMS[self.index].half + 0.04
        if (x, y, top) == self._arrow_at:
            return  # it stands there already: the simulation keeps a moved object's last pose
        self._arrow_at = (x, y, top)
        self.pending.poses["arrow_head"] = Pose((x, y, top + 0.12), DOWN)
        self.pending.poses["arrow_shaft"] = Pose((x, y, top + 0.12))

    def _values(self, target) -> dict:
        values: dict[str, Any] = {"object": ITEMS[self.index].id, "phase": self.phase, "cue": self._cue()}
        if self.position is not None:
            values["depth"] = round(abs(self.position[0] - target[0]), 6)
            values["distance"] = round(math.dist(self.position, target), 6)
        if self.hold_since is not None and self.phase == "carry":
            values["hold_s"] = round(self._last_t - self.hold_since, 3)
        for k, v in self.metrics().items():
            if v is not None:
                values[k] = v
        return values

    def _hud(self, ctx: TickContext) -> str:
        if ctx.refusals:
            return "; ".join(ctx.refusals)
        if self.phase == "idle":
            return "Pick up the object"
        if self.phase == "carry":
            if self.hold_since is not None:
                return f"Hold {max(0.0, self.hold_s - (self._last_t - self.hold_since)):.1f} s"
            return "Bring it to the arrow"
        if self.phase == "go":
            return "GO"
        return "Done" if self.trial is not None else "Done: press space for the next object"
