"""The simulation's data (MuJoCo's mjData): everything a tick changes, in one object.

A Simulation (server/loop/simulation.py) is the model, what a scenario switch replaces: the
scenario, its scene, tick_hz, the rig, and whether anyone draws the run. Everything that changes
as it runs is a SimData: the tick counter, the cues last given, the device host's refusals, the
trial, the events and trial ends not yet published, the tools (each tool's tracked point, held
point, god-object proxy, contact gate and driver: server/core/tool.py), the points that drive no
tool and who sent them, each source's ttl deadline, the lost sources, the scene's objects as the
scenario changed them (poses, visibility, drawn scale, stiffness, touchability and the bodies
built from them), and the memos the tick keys on object identity.

`copy()` copies all of it, so `Simulation.snapshot` / `restore` give back a run bit for bit (the
scenario's own state is copied beside it, see Snapshot). `carry_over(old)` is what a scenario
switch keeps of the data it replaces.

Tracker samples (`offer`) name the point their `pos` is (default: the primary tool's) and may
carry more points of the same sample (a hand). A point that names a tool moves it under the
tracker rule; the others are kept as `points` for drawing. A sample with a `ttl` (ms) is good for
that long: when no newer sample of its source came by then, the source is lost (protocol v1.4):
every tool it drives is released (home, out of contact at once), its points are dropped, and a
`tracker_lost` event {source, tools} is recorded; `tracker_back` when it sends again.
"""

from __future__ import annotations

import copy
import struct
from dataclasses import dataclass, replace
from typing import Any

from server.core.cues import Cue
from server.core.haptics.primitives import Body, Pose
from server.core.haptics.vec import Vec3
from server.core.scenario import NO_TOOL_CUES, ScenarioOutput, Trial
from server.core.scene import Scene
from server.core.tool import Tool
from server.core.workspace import clamp_to_workspace, in_workspace

TRACKER_LOST, TRACKER_BACK = "tracker_lost", "tracker_back"  # events of a source whose ttl passed, and its return
MAX_LOST_SOURCES = 8  # lost sources listed in the state at most (a restarted UDP bridge is a new source)

_POSE_BITS = struct.Struct("7d").pack


def _bits(pose: Pose) -> bytes:
    """A pose's seven numbers bit for bit (so 0.0 and -0.0 differ, as they may in arithmetic)."""
    return _POSE_BITS(*pose.pos, *pose.quat)


class SimData:
    __slots__ = ("tick", "cues", "tool_cues", "refusals", "trial", "events", "finished",
                 "tools", "tool_by_name", "points", "point_source", "deadlines", "lost_sources",
                 "moved", "visibility", "scales", "stiffness", "touch_overrides", "all_bodies", "bodies", "stale",
                 "others", "primary_view", "primary_step", "tools_view", "other_views", "nearest_memo")

    def __init__(self, tools: tuple[Tool, ...], bodies: dict[str, Body]):
        self.tick = 0
        self.cues: tuple[Cue, ...] = ()
        self.tool_cues = NO_TOOL_CUES  # the other tools' cues (ScenarioOutput.tool_cues)
        self.refusals: tuple[str, ...] = ()  # reported by the device host, through the hub
        self.trial: Trial | None = None
        self.events: list[dict] = []  # scenario events not yet published, stamped with their tick
        self.finished: list[dict] = []  # trial ends not yet published: {"tick", "metrics"}
        # -- tracking: the tools (primary first), and the module doc's points, ttls and losses
        self.tools = tools
        self.tool_by_name = {tool.name: tool for tool in tools}
        self.points: dict[str, Vec3] = {}  # latest tracked points that drive no tool (a hand, for drawing)
        self.point_source: dict[str, int | str] = {}  # who sent each of `points`
        self.deadlines: dict[int | str, float] = {}  # source → simulation time its last sample's ttl ends
        self.lost_sources: dict[int | str, tuple[str, ...]] = {}  # source → the tools it drove when lost
        # -- the scene's objects as the scenario changed them
        self.moved: dict[str, Pose] = {}  # objects whose pose differs from the scene's
        self.visibility: dict[str, bool] = {}  # objects/overlays shown or hidden against the scene
        self.scales: dict[str, tuple[float, float, float]] = {}  # objects drawn scaled (never touched scaled)
        # Stiffness and touchability overrides against the scene's;
        # replaced, never changed in place, so a tick's result keeps the set it was computed with.
        self.stiffness: dict[str, float] = {}
        self.touch_overrides: dict[str, bool] = {}  # id → False: the wire's `haptic`
        self.all_bodies = bodies  # every haptic body by id, as last built
        # The touchable ones, in scene order: a tuple, built again only when one changes, which the
        # compiled god-object recognises by identity (no per-body check of the scene each tick).
        self.bodies: tuple[Body, ...] = tuple(bodies.values())
        # Untouchable bodies moved since their Body was last built (a carried object moves every
        # tick): built again from `moved` only when they are needed (_fresh).
        self.stale: set[str] = set()
        # -- memos of the step, keyed on object identity (docs/architecture.md "One tick")
        self.others = tools[1:]  # the tools besides the primary (none: the one-tool path stays short)
        self.primary_view = None  # the primary tool's last ToolView, and the ProxyStep it showed
        self.primary_step = None
        self.tools_view = None  # the last (view,) of a one-tool simulation
        self.other_views: list[tuple | None] = [None] * len(self.others)  # (step, view) of each other tool
        self.nearest_memo: tuple = (None, None, None)  # (hip, bodies, nearest body id): Simulation._nearest_body

    def copy(self) -> SimData:
        """A copy sharing nothing that changes: every field, the tools' proxies and gates with them,
        and the memos consistent with the copied tools. Complete by construction (a deep copy: a
        field added later is copied too); a Trial and the scene's immutable parts may be shared."""
        return copy.deepcopy(self)

    @property
    def untouchable(self) -> frozenset[str]:
        """The bodies the scenario made untouchable."""
        return frozenset(self.touch_overrides)

    def carry_over(self, old: SimData) -> None:
        """What a scenario switch keeps of the data it replaces: the tick, the device host's
        refusals, the events and trial ends not yet published, and the tracking: who drives each
        tool of the same name (not where it was: the new scene has its own home), the drawn
        points, ttls and lost sources. The scene's objects, cues and trial start anew."""
        self.tick, self.refusals = old.tick, old.refusals
        self.events, self.finished = old.events, old.finished
        for previous in old.tools:
            tool = self.tool_by_name.get(previous.name)
            if tool is not None:
                tool.take_driver(previous)
        self.points, self.point_source = old.points, old.point_source
        self.deadlines, self.lost_sources = old.deadlines, old.lost_sources

    # -- tracker samples (module doc) ------------------------------------------------------------
    def offer(self, source: int | str, seq: int, pos: Vec3, point: str | None, points: dict[str, Vec3] | None,
              ttl_ms: float | None, t_s: float) -> bool:
        """One tracker sample at simulation time `t_s` (Simulation.offer)."""
        if source in self.lost_sources:
            self._back(source, t_s)
        applied = self._offer_point(source, seq, point or self.tools[0].name, pos, t_s)
        if points:
            for name, position in points.items():
                applied = self._offer_point(source, seq, name, position, t_s) or applied
        if ttl_ms is not None and applied:
            self.deadlines[source] = t_s + ttl_ms / 1000.0
        elif source in self.deadlines and ttl_ms is None:
            del self.deadlines[source]  # the source now sends without ttl: held as the mouse is
        return applied

    def _offer_point(self, source: int | str, seq: int, name: str, pos: Vec3, t_s: float) -> bool:
        tool = self.tool_by_name.get(name)
        if tool is not None:
            if tool.offer(source, seq, pos, t_s):
                if self.lost_sources:
                    self._forget_recovered()
                return True
            return False
        self.points[name] = pos if in_workspace(pos) else clamp_to_workspace(pos)
        self.point_source[name] = source
        return True

    def release(self, source: int | str) -> None:
        """`source` left (a /ws client disconnected): its tools go home, its points go."""
        for tool in self.tools:
            tool.release(source)
        self.deadlines.pop(source, None)
        self.lost_sources.pop(source, None)
        self._drop_points(source)

    def expire(self, tick: int, t_s: float) -> None:
        """Sources whose last sample's ttl has passed are lost (module doc)."""
        for source, deadline in list(self.deadlines.items()):
            if t_s < deadline:
                continue
            del self.deadlines[source]
            names = tuple(tool.name for tool in self.tools if tool.lose(source))
            self._drop_points(source)
            self.lost_sources[source] = names
            while len(self.lost_sources) > MAX_LOST_SOURCES:
                del self.lost_sources[next(iter(self.lost_sources))]
            self.events.append({"tick": tick, "t": t_s, "name": TRACKER_LOST, "source": source,
                                "tools": list(names)})

    def _back(self, source: int | str, t_s: float) -> None:
        names = self.lost_sources.pop(source)
        self.events.append({"tick": self.tick, "t": t_s, "name": TRACKER_BACK, "source": source,
                            "tools": list(names)})

    def _forget_recovered(self) -> None:
        """A lost source none of whose tools is lost any more (another source drives them) is no
        longer listed as lost."""
        for source, names in list(self.lost_sources.items()):
            if names and not any(self.tool_by_name[n].lost for n in names):
                del self.lost_sources[source]

    def _drop_points(self, source: int | str) -> None:
        for name in [n for n, s in self.point_source.items() if s == source]:
            del self.points[name], self.point_source[name]

    # -- the scenario's changes to its objects ---------------------------------------------------
    def apply_changes(self, output: ScenarioOutput, scene: Scene) -> None:
        """A step's poses, stiffness, touchability, scales and visibility, for the next tick;
        KeyError for an id `scene` does not have."""
        all_bodies, moved = self.all_bodies, self.moved
        bodies_changed = False
        for object_id, pose in output.poses.items():
            last = moved.get(object_id)
            if last is not None and (last is pose or (last.pos == pose.pos and _bits(last) == _bits(pose))):
                continue  # where it is already (a carried object between tracker samples): same body, same row
            body = all_bodies.get(object_id)
            if body is not None:
                if object_id in self.touch_overrides:  # untouchable (a carried object): no god-object sees it
                    self.stale.add(object_id)  # its Body follows `moved` when it is needed (_fresh)
                else:
                    all_bodies[object_id] = replace(body, pose=pose)
                    bodies_changed = True
            elif not scene.has_id(object_id):  # drawn-only objects move too, they just have no body
                raise KeyError(f"scenario moves {object_id!r}, which is not in scene {scene.name!r}")
            moved[object_id] = pose
        if output.stiffness:
            bodies_changed = True
            stiffness = dict(self.stiffness)
            for object_id, k in output.stiffness.items():
                all_bodies[object_id] = replace(self._body(object_id, scene), stiffness_n_per_m=k)
                if k == scene.object(object_id).material.stiffness_n_per_m:
                    stiffness.pop(object_id, None)
                else:
                    stiffness[object_id] = k
            self.stiffness = stiffness
        if output.touchable:
            bodies_changed = True
            untouchable = dict(self.touch_overrides)
            for object_id, on in output.touchable.items():
                self._body(object_id, scene)
                if on:  # every body of the scene is touchable there (Scene.bodies)
                    untouchable.pop(object_id, None)
                else:
                    untouchable[object_id] = False
            self.touch_overrides = untouchable
        for object_id, factors in output.scales.items():
            if not scene.has_id(object_id):
                raise KeyError(f"scenario scales {object_id!r}, which is not in scene {scene.name!r}")
            if tuple(factors) == (1.0, 1.0, 1.0):
                self.scales.pop(object_id, None)
            else:
                self.scales[object_id] = tuple(factors)
        for element_id, shown in output.visible.items():
            if not scene.has_id(element_id):
                raise KeyError(f"scenario shows/hides {element_id!r}, which is not in scene {scene.name!r}")
            self.visibility[element_id] = shown
        if bodies_changed:
            if self.stale:
                self._fresh()
            self.bodies = tuple(b for b in all_bodies.values() if b.id not in self.touch_overrides)
            for tool in self.tools:
                tool.forget_fixed_point()  # the fixed point may have moved with the bodies

    def _fresh(self) -> None:
        """Untouchable bodies moved meanwhile take their last pose (before they count again)."""
        for object_id in self.stale:
            self.all_bodies[object_id] = replace(self.all_bodies[object_id], pose=self.moved[object_id])
        self.stale.clear()

    def _body(self, object_id: str, scene: Scene) -> Body:
        if object_id in self.stale:
            self._fresh()
        try:
            return self.all_bodies[object_id]
        except KeyError:
            raise KeyError(f"scenario changes {object_id!r}, which is not a haptic object of scene "
                           f"{scene.name!r}") from None


@dataclass(frozen=True)
class Snapshot:
    """A simulation at one tick (Simulation.snapshot): its data, and the scenario's own state (a
    scenario keeps its phase, timers and random generator on itself, Gymnasium-like), both copies
    that `Simulation.restore` copies again, so one snapshot restores any number of times."""
    data: SimData
    scenario: dict[str, Any]
    scene: str  # the hash of the scene it was taken on: restored only onto that scene
