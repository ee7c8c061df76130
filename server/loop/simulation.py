"""One tick of the haptic simulation, with no I/O (MuJoCo's mj_step for ViESTac).

Pipeline per tick: latest tracker sample (held between samples: zero-order hold; or the point
the scenario holds the HIP at, for the experimenter's "tap") → god-object proxy against the
scene's analytic bodies → debounced contact (hysteresis gate, for vibration-only devices) →
scenario step → device-independent cues, plus the scenario's changes to its objects (poses,
visibility, touchability, stiffness), applied for the next tick. The tracked point, its proxy and
its gate are a Tool (server/core/tool.py); the simulation owns a tuple of tools, one per rig
point (the primary, the HIP, first; more fingers: more tools, each its own god-object against the
scene's bodies, never against each other), which the scenario sees in its TickContext. Time is the tick counter
(t = tick / tick_hz), never a clock read, so the same inputs give the same outputs whether the
loop runs in real time, on a virtual clock, or replays a recorded trajectory.

Tracker samples (`offer`) name the point their `pos` is (default: the primary tool's) and may
carry more points of the same sample (a hand). A point that names a tool moves it under the
tracker rule; the others are kept as `points` for drawing. A sample with a `ttl` (ms) is good for
that long: when no newer sample of its source came by then, the source is lost (protocol v1.4):
every tool it drives is released (home, out of contact at once), its points are dropped, and a
`tracker_lost` event {source, tools} is recorded; `tracker_back` when it sends again.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, replace
from typing import Any

from server.core.cues import Cue
from server.core.frozen import quick_init
from server.core.scenario import Scenario, ScenarioOutput, TickContext, ToolView, Trial
from server.core.haptics.contact_gate import ContactGate
from server.core.haptics.god_object import Contact
from server.core.haptics.primitives import Body, Pose
from server.core.haptics.vec import Vec3
from server.core.points import PRIMARY_POINT, check_point_name
from server.core.scene import Scene
from server.core.tool import Tool
from server.core.workspace import clamp_to_workspace, in_workspace

_POSE_BITS = struct.Struct("7d").pack


def _bits(pose: Pose) -> bytes:
    """A pose's seven numbers bit for bit (so 0.0 and -0.0 differ, as they may in arithmetic)."""
    return _POSE_BITS(*pose.pos, *pose.quat)


TRIAL_DONE = "trial_done"  # the event a trial's end is also shown as (clients and exports list events)
TRACKER_LOST, TRACKER_BACK = "tracker_lost", "tracker_back"  # events of a source whose ttl passed, and its return
MAX_LOST_SOURCES = 8  # lost sources listed in the state at most (a restarted UDP bridge is a new source)


@quick_init  # built every tick (server/core/frozen.py)
@dataclass(frozen=True)
class TickResult:
    tick: int
    t_s: float
    hip: Vec3
    proxy: Vec3
    force: Vec3
    contacts: tuple[Contact, ...]
    contact: bool            # debounced
    output: ScenarioOutput
    cues_changed: bool       # the active cue set differs from the previous tick's
    stiffness: dict[str, float]  # the stiffness overrides this tick's force was computed with
    haptic: dict[str, bool]  # the touchability overrides this tick's contacts were found with
    tools: tuple[ToolView, ...] = ()  # every tool this tick, primary first (hip/proxy/... above are tools[0])


def home_position(scene: Scene) -> Vec3:
    """Where the HIP rests before the first tracker sample: high in the view, above the scene."""
    cam = scene.camera
    lift = 0.3 * cam.height if cam.projection == "orthographic" else 0.5
    return (cam.target[0] + cam.up[0] * lift, cam.target[1] + cam.up[1] * lift, cam.target[2] + cam.up[2] * lift)


def tool_names(rig: tuple[str, ...] = (), fingers: tuple[str, ...] = ()) -> tuple[str, ...]:
    """The tools of a simulation: the primary point, then the rig's fingers, then what the
    scenario needs besides, each once (ValueError for a name that is not a point name)."""
    names: list[str] = [PRIMARY_POINT]
    for name in (*rig, *fingers):
        if check_point_name(name) not in names:
            names.append(name)
    return tuple(names)


def _gate_like(gate: ContactGate | None) -> ContactGate | None:
    return None if gate is None else ContactGate(gate.band, gate.min_on_s, gate.min_off_s)


class Simulation:
    def __init__(self, scenario: Scenario, *, tick_hz: int = 1000, gate: ContactGate | None = None,
                 seed: int = 0, scene: Scene | None = None, rig: tuple[str, ...] = ()):
        if tick_hz <= 0:
            raise ValueError("tick_hz must be positive")
        self.scenario = scenario
        self.scene = scene if scene is not None else scenario.build_scene()
        self.tick_hz = tick_hz
        self.rig = tuple(rig)  # the rig's fingers besides the primary point (devices' `finger`)
        # The tracked points, one tool each; the scenario's hip/proxy/contact are the first's.
        names = tool_names(self.rig, tuple(getattr(type(scenario), "fingers", ())))
        home = home_position(self.scene)
        self.tools: tuple[Tool, ...] = tuple(
            Tool(home, self.scene.proxy_radius, gate if i == 0 else _gate_like(gate), name)
            for i, name in enumerate(names))
        self.tool_by_name = {tool.name: tool for tool in self.tools}
        self._others = self.tools[1:]  # the tools besides the primary (none: the one-tool path stays short)
        self._primary_view: ToolView | None = None  # the primary tool's last view and the step it showed
        self._primary_step = None
        self._tools_view: tuple[ToolView, ...] | None = None
        self._other_views: list[tuple | None] = [None] * len(self._others)  # (step, view) of each other tool
        self.points: dict[str, Vec3] = {}  # latest tracked points that drive no tool (a hand, for drawing)
        self._point_source: dict[str, int | str] = {}  # who sent each of `points`
        self._deadlines: dict[int | str, float] = {}  # source → simulation time its last sample's ttl ends
        self.lost_sources: dict[int | str, tuple[str, ...]] = {}  # source → the tools it drove when lost
        self._all_bodies = {b.id: b for b in self.scene.bodies()}
        # The touchable ones, in scene order: a tuple, built again only when one changes, which the
        # compiled god-object recognises by identity (no per-body check of the scene each tick).
        self.bodies: tuple[Body, ...] = tuple(self._all_bodies.values())
        # Untouchable bodies moved since their Body was last built (a carried object moves every
        # tick): built again from `moved` only when they are needed (_fresh).
        self._stale: set[str] = set()
        self._nearest_memo: tuple = (None, None, None)  # (hip, bodies, nearest body id): _nearest_body
        self.moved: dict[str, Pose] = {}  # objects whose pose differs from the scene's
        self.visibility: dict[str, bool] = {}  # objects/overlays shown or hidden against the scene
        self.scales: dict[str, tuple[float, float, float]] = {}  # objects drawn scaled (never touched scaled)
        # Stiffness and touchability against the scene's; replaced, never changed in place, so a
        # tick's result keeps the set it was computed with.
        self.stiffness: dict[str, float] = {}
        self.haptic: dict[str, bool] = {}
        self.tick = 0
        self.cues: tuple[Cue, ...] = ()
        self.tool_cues = ScenarioOutput.tool_cues  # the other tools' cues (ScenarioOutput.tool_cues)
        self.refusals: tuple[str, ...] = ()  # reported by the device host, through the hub
        self.events: list[dict] = []  # scenario events not yet published, stamped with their tick
        self.finished: list[dict] = []  # trial ends not yet published: {"tick", "metrics"}
        self.trial: Trial | None = None
        self.drawn = True  # someone draws the state (TickContext.drawn); set by LoopCore
        scenario.reset(seed)

    @property
    def tool(self) -> Tool:
        """The HIP: the tool the scenario sees."""
        return self.tools[0]

    @property
    def hip(self) -> Vec3:
        """The HIP's tracked position (a held position, if any, overrides it in the step)."""
        return self.tools[0].tracked

    @property
    def untouchable(self) -> frozenset[str]:
        """The bodies the scenario made untouchable."""
        return frozenset(self.haptic)

    def set_hip(self, position: Vec3) -> None:
        """Move the HIP directly (no tracker rule: offline rendering, a simulated participant);
        applied at the next step (parameters change between ticks only); clamped to the workspace."""
        self.tools[0].place(position)

    # -- tracker samples (module doc) ------------------------------------------------------------
    def offer(self, source: int | str, seq: int, pos: Vec3, point: str | None = None,
              points: dict[str, Vec3] | None = None, ttl_ms: float | None = None) -> bool:
        """One tracker sample, applied at the next step; True when it moved a tool or a point.
        `pos` is the point `point` (default: the primary tool's); `points` more points of it."""
        t_s = self.tick / self.tick_hz
        if source in self.lost_sources:
            self._back(source, t_s)
        applied = self._offer_point(source, seq, point or self.tools[0].name, pos, t_s)
        if points:
            for name, position in points.items():
                applied = self._offer_point(source, seq, name, position, t_s) or applied
        if ttl_ms is not None and applied:
            self._deadlines[source] = t_s + ttl_ms / 1000.0
        elif source in self._deadlines and ttl_ms is None:
            del self._deadlines[source]  # the source now sends without ttl: held as the mouse is
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
        self._point_source[name] = source
        return True

    def release(self, source: int | str) -> None:
        """`source` left (a /ws client disconnected): its tools go home, its points go."""
        for tool in self.tools:
            tool.release(source)
        self._deadlines.pop(source, None)
        self.lost_sources.pop(source, None)
        self._drop_points(source)

    def _expire(self, tick: int, t_s: float) -> None:
        """Sources whose last sample's ttl has passed are lost (module doc)."""
        for source, deadline in list(self._deadlines.items()):
            if t_s < deadline:
                continue
            del self._deadlines[source]
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

    def carry_tracking(self, old: Simulation) -> None:
        """A rebuilt simulation (a scenario switch) keeps the tracked points, ttls and lost sources."""
        self.points, self._point_source = old.points, old._point_source
        self._deadlines, self.lost_sources = old._deadlines, old.lost_sources

    def _drop_points(self, source: int | str) -> None:
        for name in [n for n, s in self._point_source.items() if s == source]:
            del self.points[name], self._point_source[name]

    def input(self, key: str, action: str, value: Any = None) -> None:
        self.scenario.on_input(key, action, value)

    def set_trial(self, trial: Trial | None) -> None:
        self.trial = trial
        self.scenario.set_trial(trial)

    def _nearest_body(self, hip: Vec3) -> str | None:
        memo = self._nearest_memo  # the HIP is held between tracker samples: same point, same bodies
        if memo[0] is hip and memo[1] is self.bodies:
            return memo[2]
        best, best_d = None, float("inf")
        for body in self.bodies:
            d = body._eval(hip)[0]  # Body.signed_distance without its call
            if d < best_d:
                best, best_d = body.id, d
        self._nearest_memo = (hip, self.bodies, best)
        return best

    def step(self) -> TickResult:
        tick = self.tick
        t_s = tick / self.tick_hz
        if self._deadlines:
            self._expire(tick, t_s)
        tool = self.tools[0]
        hip = tool.hip
        stiffness, haptic = self.stiffness, self.haptic  # what this tick renders with
        proxy_step = tool.proxy_step(self.bodies, hip)
        contacts = proxy_step.contacts
        contact = tool.gate.update(t_s, bool(contacts), proxy_step.separation)
        last = self._primary_view
        if proxy_step is self._primary_step and last.contact == contact and last.hip is hip and last.lost == tool.lost:
            # Held between tracker samples at a fixed point of the god-object (Tool.proxy_step
            # returned the same step): the view of the last tick is this tick's, built once.
            view, touching = last, last.touching
        else:
            touching = frozenset(c.body_id for c in contacts)
            view = ToolView(tool.name, hip, proxy_step.proxy, contact, touching, proxy_step.force, tool.lost)
            self._primary_view, self._primary_step = view, proxy_step
        others = self._others
        if others:
            tools = (view, *self._render_others(others, t_s))
        elif view is not last or self._tools_view is None:
            tools = self._tools_view = (view,)
        else:
            tools = self._tools_view
        nearest = self._nearest_body(hip) if contact else None
        ctx = TickContext(tick, t_s, hip, proxy_step.proxy, contact, touching, nearest, self.refusals,
                          tool.god.sticking, tools, self.drawn)
        output = self.scenario.step(ctx)
        if output.poses or output.haptic or output.stiffness or output.visible or output.scales:
            self._apply_changes(output)
        if output.hold_hip != tool.held:
            tool.hold(output.hold_hip, self.bodies)
        if output.events or output.finished is not None:
            self._stamp(tick, t_s, output)
        tool_cues = output.tool_cues
        cues = output.cues  # a scenario that keeps its cue tuple while nothing changes skips the compare
        cues_changed = (cues is not self.cues and cues != self.cues) or (
            tool_cues is not self.tool_cues and tool_cues != self.tool_cues)
        self.cues = cues
        self.tool_cues = tool_cues
        self.tick = tick + 1
        return TickResult(tick, t_s, hip, proxy_step.proxy, proxy_step.force, contacts, contact,
                          output, cues_changed, stiffness, haptic, tools)

    def _render_others(self, others: tuple[Tool, ...], t_s: float) -> list[ToolView]:
        """The tools other than the primary, in one loop: each its own god-object against the
        bodies and its own gate. A tool whose step and gate did not change (its HIP held between
        samples at a fixed point) shows the view it showed last tick."""
        bodies = self.bodies
        views = self._other_views
        out = []
        for i, tool in enumerate(others):
            hip = tool.hip
            step = tool.proxy_step(bodies, hip)
            contacts = step.contacts
            contact = tool.gate.update(t_s, bool(contacts), step.separation)
            last = views[i]
            if last is None or last[0] is not step or last[1].contact != contact or last[1].hip is not hip \
                    or last[1].lost != tool.lost:
                view = ToolView(tool.name, hip, step.proxy, contact, frozenset(c.body_id for c in contacts),
                                step.force, tool.lost)
                last = views[i] = (step, view)
            out.append(last[1])
        return out

    def _stamp(self, tick: int, t_s: float, output: ScenarioOutput) -> None:
        """Events with their tick; a trial's end as a `finished` entry and as a trial_done event."""
        finished = output.finished
        done_event = False
        for event in output.events:
            done_event = done_event or event.get("name") == TRIAL_DONE
            self.events.append({"tick": tick, "t": t_s, **event})
        if finished is not None:
            if not done_event:
                self.events.append({"tick": tick, "t": t_s, "name": TRIAL_DONE, **finished})
            self.finished.append({"tick": tick, "metrics": dict(finished)})

    def _apply_changes(self, output: ScenarioOutput) -> None:
        all_bodies, moved = self._all_bodies, self.moved
        bodies_changed = False
        for object_id, pose in output.poses.items():
            last = moved.get(object_id)
            if last is not None and (last is pose or (last.pos == pose.pos and _bits(last) == _bits(pose))):
                continue  # where it is already (a carried object between tracker samples): same body, same row
            body = all_bodies.get(object_id)
            if body is not None:
                if object_id in self.haptic:  # untouchable (a carried object): no god-object sees it
                    self._stale.add(object_id)  # its Body follows `moved` when it is needed (_fresh)
                else:
                    all_bodies[object_id] = replace(body, pose=pose)
                    bodies_changed = True
            elif not self.scene.has_id(object_id):  # drawn-only objects move too, they just have no body
                raise KeyError(f"scenario moves {object_id!r}, which is not in scene {self.scene.name!r}")
            moved[object_id] = pose
        if output.stiffness:
            bodies_changed = True
            stiffness = dict(self.stiffness)
            for object_id, k in output.stiffness.items():
                self._all_bodies[object_id] = replace(self._body(object_id), stiffness_n_per_m=k)
                if k == self.scene.object(object_id).material.stiffness_n_per_m:
                    stiffness.pop(object_id, None)
                else:
                    stiffness[object_id] = k
            self.stiffness = stiffness
        if output.haptic:
            bodies_changed = True
            haptic = dict(self.haptic)
            for object_id, on in output.haptic.items():
                self._body(object_id)
                if on:  # every body of the scene is touchable there (Scene.bodies)
                    haptic.pop(object_id, None)
                else:
                    haptic[object_id] = False
            self.haptic = haptic
        for object_id, factors in output.scales.items():
            if not self.scene.has_id(object_id):
                raise KeyError(f"scenario scales {object_id!r}, which is not in scene {self.scene.name!r}")
            if tuple(factors) == (1.0, 1.0, 1.0):
                self.scales.pop(object_id, None)
            else:
                self.scales[object_id] = tuple(factors)
        for element_id, shown in output.visible.items():
            if not self.scene.has_id(element_id):
                raise KeyError(f"scenario shows/hides {element_id!r}, which is not in scene {self.scene.name!r}")
            self.visibility[element_id] = shown
        if bodies_changed:
            if self._stale:
                self._fresh()
            self.bodies = tuple(b for b in all_bodies.values() if b.id not in self.haptic)
            for tool in self.tools:
                tool.forget_fixed_point()  # the fixed point may have moved with the bodies

    def _fresh(self) -> None:
        """Untouchable bodies moved meanwhile take their last pose (before they count again)."""
        for object_id in self._stale:
            self._all_bodies[object_id] = replace(self._all_bodies[object_id], pose=self.moved[object_id])
        self._stale.clear()

    def _body(self, object_id: str):
        if object_id in self._stale:
            self._fresh()
        try:
            return self._all_bodies[object_id]
        except KeyError:
            raise KeyError(f"scenario changes {object_id!r}, which is not a haptic object of scene "
                           f"{self.scene.name!r}") from None
