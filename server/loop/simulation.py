"""One tick of the haptic simulation, with no I/O (MuJoCo's mj_step for ViESTac).

Pipeline per tick: latest tracker sample (held between samples: zero-order hold; or the point
the scenario holds the HIP at, for the experimenter's "tap") → god-object proxy against the
scene's analytic bodies → debounced contact (hysteresis gate, for vibration-only devices) →
scenario step → device-independent cues, plus the scenario's changes to its objects (poses,
visibility, touchability, stiffness), applied for the next tick. The tracked point, its proxy and
its gate are a Tool (server/core/tool.py); the simulation's data has a tuple of tools, one per
rig point (the primary, the HIP, first; more fingers: more tools, each its own god-object against
the scene's bodies, never against each other), which the scenario sees in its TickContext. Time
is the tick counter (t = tick / tick_hz), never a clock read, so the same inputs give the same outputs whether the
loop runs in real time, on a virtual clock, or replays a recorded trajectory.

Model and data, as MuJoCo splits them: a Simulation is the model, what a scenario switch
replaces (the scenario, its scene, tick_hz, the rig, whether the run is drawn); everything a tick
changes is its `data`, one SimData (server/loop/sim_data.py: the tick, the tools and who drives
them, the scene's objects as the scenario changed them, events, ...). `snapshot()` / `restore()`
copy the data and the scenario's own state, so a run resumes from a snapshot bit for bit; a
scenario switch keeps what it keeps through `SimData.carry_over`. Tracker samples (`offer`) and
their ttls: server/loop/sim_data.py.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any

from server.core.frozen import quick_init
from server.core.scenario import Scenario, ScenarioOutput, TickContext, ToolView, Trial
from server.core.haptics.contact_gate import ContactGate
from server.core.haptics.god_object import Contact
from server.core.haptics.vec import Vec3
from server.core.points import PRIMARY_POINT, check_point_name
from server.core.scene import Scene
from server.core.tool import Tool
from server.loop.sim_data import SimData, Snapshot

TRIAL_DONE = "trial_done"  # the event a trial's end is also shown as (clients and exports list events)


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
    touch_overrides: dict[str, bool]  # the bodies made untouchable (→ False) this tick's contacts were found with
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
        self.drawn = True  # someone draws the state (TickContext.drawn); set by Loop
        # The tracked points, one tool each; the scenario's hip/proxy/contact are the first's.
        names = tool_names(self.rig, tuple(getattr(type(scenario), "fingers", ())))
        home = home_position(self.scene)
        tools = tuple(Tool(home, self.scene.proxy_radius, gate if i == 0 else _gate_like(gate), name)
                      for i, name in enumerate(names))
        self.data = SimData(tools, {b.id: b for b in self.scene.bodies()})
        scenario.reset(seed)

    @property
    def tool(self) -> Tool:
        """The HIP: the tool the scenario sees."""
        return self.data.tools[0]

    def set_hip(self, position: Vec3) -> None:
        """Move the HIP directly (no tracker rule: offline rendering, a simulated participant);
        applied at the next step (parameters change between ticks only); clamped to the workspace."""
        self.data.tools[0].place(position)

    def offer(self, source: int | str, seq: int, pos: Vec3, point: str | None = None,
              points: dict[str, Vec3] | None = None, ttl_ms: float | None = None) -> bool:
        """One tracker sample, applied at the next step; True when it moved a tool or a point.
        `pos` is the point `point` (default: the primary tool's); `points` more points of it."""
        data = self.data
        return data.offer(source, seq, pos, point, points, ttl_ms, data.tick / self.tick_hz)

    def release(self, source: int | str) -> None:
        """`source` left (a /ws client disconnected): its tools go home, its points go."""
        self.data.release(source)

    def input(self, key: str, action: str, value: Any = None) -> None:
        self.scenario.on_input(key, action, value)

    def set_trial(self, trial: Trial | None) -> None:
        self.data.trial = trial
        self.scenario.set_trial(trial)

    # -- snapshots (module doc) ------------------------------------------------------------------
    def snapshot(self) -> Snapshot:
        """The run as it stands between two ticks, for `restore` (any number of times)."""
        # the memo makes a scenario's reference to the scene (the model) a reference, not a copy
        return Snapshot(self.data.copy(), copy.deepcopy(vars(self.scenario), {id(self.scene): self.scene}),
                        self.scene.hash)

    def restore(self, snapshot: Snapshot) -> None:
        """Back to `snapshot` (of this simulation): the next steps are those that followed it, bit
        for bit, given the same inputs. The model (scenario object, scene) stays as it is."""
        if snapshot.scene != self.scene.hash:
            raise ValueError(f"a snapshot of another scene than {self.scene.name!r}")
        self.data = snapshot.data.copy()
        state = vars(self.scenario)
        state.clear()
        state.update(copy.deepcopy(snapshot.scenario, {id(self.scene): self.scene}))

    # -- the step ----------------------------------------------------------------------------------
    def _nearest_body(self, hip: Vec3) -> str | None:
        data = self.data
        memo = data.nearest_memo  # the HIP is held between tracker samples: same point, same bodies
        if memo[0] is hip and memo[1] is data.bodies:
            return memo[2]
        best, best_d = None, float("inf")
        for body in data.bodies:
            d = body._eval(hip)[0]  # Body.signed_distance without its call
            if d < best_d:
                best, best_d = body.id, d
        data.nearest_memo = (hip, data.bodies, best)
        return best

    def step(self) -> TickResult:
        data = self.data
        tick = data.tick
        t_s = tick / self.tick_hz
        if data.deadlines:
            data.expire(tick, t_s)
        tool = data.tools[0]
        hip = tool.hip
        stiffness, touch_overrides = data.stiffness, data.touch_overrides  # what this tick renders with
        proxy_step = tool.proxy_step(data.bodies, hip)
        contacts = proxy_step.contacts
        contact = tool.gate.update(t_s, bool(contacts), proxy_step.separation)
        last = data.primary_view
        driven = tool.driver is not None
        if proxy_step is data.primary_step and last.contact == contact and last.hip is hip and last.lost == tool.lost \
                and last.driven == driven:
            # Held between tracker samples at a fixed point of the god-object (Tool.proxy_step
            # returned the same step): the view of the last tick is this tick's, built once.
            view, touching = last, last.touching
        else:
            touching = frozenset(c.body_id for c in contacts)
            view = ToolView(tool.name, hip, proxy_step.proxy, contact, touching, proxy_step.force, tool.lost, driven)
            data.primary_view, data.primary_step = view, proxy_step
        others = data.others
        if others:
            tools = (view, *self._render_others(others, t_s))
        elif view is not last or data.tools_view is None:
            tools = data.tools_view = (view,)
        else:
            tools = data.tools_view
        nearest = self._nearest_body(hip) if contact else None
        ctx = TickContext(tick, t_s, hip, proxy_step.proxy, contact, touching, nearest, data.refusals,
                          tool.god.sticking, tools, self.drawn)
        output = self.scenario.step(ctx)
        if output.poses or output.touchable or output.stiffness or output.visible or output.scales:
            data.apply_changes(output, self.scene)
        if output.hold_hip != tool.held:
            tool.hold(output.hold_hip, data.bodies)
        if output.events or output.finished is not None:
            self._stamp(tick, t_s, output)
        tool_cues = output.tool_cues
        cues = output.cues  # a scenario that keeps its cue tuple while nothing changes skips the compare
        cues_changed = (cues is not data.cues and cues != data.cues) or (
            tool_cues is not data.tool_cues and tool_cues != data.tool_cues)
        data.cues = cues
        data.tool_cues = tool_cues
        data.tick = tick + 1
        return TickResult(tick, t_s, hip, proxy_step.proxy, proxy_step.force, contacts, contact,
                          output, cues_changed, stiffness, touch_overrides, tools)

    def _render_others(self, others: tuple[Tool, ...], t_s: float) -> list[ToolView]:
        """The tools other than the primary, in one loop: each its own god-object against the
        bodies and its own gate. A tool whose step and gate did not change (its HIP held between
        samples at a fixed point) shows the view it showed last tick."""
        data = self.data
        bodies, views = data.bodies, data.other_views
        out = []
        for i, tool in enumerate(others):
            hip = tool.hip
            step = tool.proxy_step(bodies, hip)
            contacts = step.contacts
            contact = tool.gate.update(t_s, bool(contacts), step.separation)
            last = views[i]
            driven = tool.driver is not None
            if last is None or last[0] is not step or last[1].contact != contact or last[1].hip is not hip \
                    or last[1].lost != tool.lost or last[1].driven != driven:
                view = ToolView(tool.name, hip, step.proxy, contact, frozenset(c.body_id for c in contacts),
                                step.force, tool.lost, driven)
                last = views[i] = (step, view)
            out.append(last[1])
        return out

    def _stamp(self, tick: int, t_s: float, output: ScenarioOutput) -> None:
        """Events with their tick; a trial's end as a `finished` entry and as a trial_done event."""
        finished = output.finished
        events = self.data.events
        done_event = False
        for event in output.events:
            done_event = done_event or event.get("name") == TRIAL_DONE
            events.append({"tick": tick, "t": t_s, **event})
        if finished is not None:
            if not done_event:
                events.append({"tick": tick, "t": t_s, "name": TRIAL_DONE, **finished})
            self.data.finished.append({"tick": tick, "metrics": dict(finished)})
