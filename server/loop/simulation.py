"""One tick of the haptic simulation, with no I/O (MuJoCo's mj_step for ViESTac).

Pipeline per tick: latest tracker sample (held between samples: zero-order hold; or the point
the scenario holds the HIP at, for the experimenter's "tap") → god-object proxy against the
scene's analytic bodies → debounced contact (hysteresis gate, for vibration-only devices) →
scenario step → device-independent cues, plus the scenario's changes to its objects (poses,
visibility, touchability, stiffness), applied for the next tick. The tracked point, its proxy and
its gate are a Tool (server/core/tool.py); the simulation owns a tuple of tools, today one (the
HIP), which the scenario sees in its TickContext. Time is the tick counter
(t = tick / tick_hz), never a clock read, so the same inputs give the same outputs whether the
loop runs in real time, on a virtual clock, or replays a recorded trajectory.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from server.core.cues import Cue
from server.core.scenario import Scenario, ScenarioOutput, TickContext, Trial
from server.core.haptics.contact_gate import ContactGate
from server.core.haptics.god_object import Contact
from server.core.haptics.primitives import Pose
from server.core.haptics.vec import Vec3
from server.core.scene import Scene
from server.core.tool import Tool

TRIAL_DONE = "trial_done"  # the event a trial's end is also shown as (clients and exports list events)


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


def home_position(scene: Scene) -> Vec3:
    """Where the HIP rests before the first tracker sample: high in the view, above the scene."""
    cam = scene.camera
    lift = 0.3 * cam.height if cam.projection == "orthographic" else 0.5
    return (cam.target[0] + cam.up[0] * lift, cam.target[1] + cam.up[1] * lift, cam.target[2] + cam.up[2] * lift)


class Simulation:
    def __init__(self, scenario: Scenario, *, tick_hz: int = 1000, gate: ContactGate | None = None,
                 seed: int = 0, scene: Scene | None = None):
        if tick_hz <= 0:
            raise ValueError("tick_hz must be positive")
        self.scenario = scenario
        self.scene = scene if scene is not None else scenario.build_scene()
        self.tick_hz = tick_hz
        # The tracked points; the scenario sees the first (the HIP). More fingers: more tools.
        self.tools: tuple[Tool, ...] = (Tool(home_position(self.scene), self.scene.proxy_radius, gate),)
        self._all_bodies = {b.id: b for b in self.scene.bodies()}
        self.bodies = list(self._all_bodies.values())  # the touchable ones, in scene order
        self.moved: dict[str, Pose] = {}  # objects whose pose differs from the scene's
        self.visibility: dict[str, bool] = {}  # objects/overlays shown or hidden against the scene
        self.scales: dict[str, tuple[float, float, float]] = {}  # objects drawn scaled (never touched scaled)
        # Stiffness and touchability against the scene's; replaced, never changed in place, so a
        # tick's result keeps the set it was computed with.
        self.stiffness: dict[str, float] = {}
        self.haptic: dict[str, bool] = {}
        self.tick = 0
        self.cues: tuple[Cue, ...] = ()
        self.refusals: tuple[str, ...] = ()  # reported by the device host, through the hub
        self.events: list[dict] = []  # scenario events not yet published, stamped with their tick
        self.finished: list[dict] = []  # trial ends not yet published: {"tick", "metrics"}
        self.trial: Trial | None = None
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

    def input(self, key: str, action: str, value: Any = None) -> None:
        self.scenario.on_input(key, action, value)

    def set_trial(self, trial: Trial | None) -> None:
        self.trial = trial
        self.scenario.set_trial(trial)

    def _nearest_body(self, hip: Vec3) -> str | None:
        best, best_d = None, float("inf")
        for body in self.bodies:
            d = body.signed_distance(hip)
            if d < best_d:
                best, best_d = body.id, d
        return best

    def step(self) -> TickResult:
        tick = self.tick
        t_s = tick / self.tick_hz
        tool = self.tools[0]
        hip = tool.hip
        stiffness, haptic = self.stiffness, self.haptic  # what this tick renders with
        proxy_step = tool.proxy_step(self.bodies, hip)
        contacts = proxy_step.contacts
        contact = tool.gate.update(t_s, bool(contacts), proxy_step.separation)
        touching = frozenset(c.body_id for c in contacts)
        nearest = self._nearest_body(hip) if contact else None
        ctx = TickContext(tick, t_s, hip, proxy_step.proxy, contact, touching, nearest, self.refusals,
                          tool.god.sticking)
        output = self.scenario.step(ctx)
        if output.poses or output.haptic or output.stiffness or output.visible or output.scales:
            self._apply_changes(output)
        if output.hold_hip != tool.held:
            tool.hold(output.hold_hip, self.bodies)
        if output.events or output.finished is not None:
            self._stamp(tick, t_s, output)
        cues_changed = output.cues != self.cues
        self.cues = output.cues
        self.tick = tick + 1
        return TickResult(tick, t_s, hip, proxy_step.proxy, proxy_step.force, contacts, contact,
                          output, cues_changed, stiffness, haptic)

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
        for object_id, pose in output.poses.items():
            if object_id in self._all_bodies:
                self._all_bodies[object_id] = replace(self._all_bodies[object_id], pose=pose)
            elif not self.scene.has_id(object_id):  # drawn-only objects move too, they just have no body
                raise KeyError(f"scenario moves {object_id!r}, which is not in scene {self.scene.name!r}")
            self.moved[object_id] = pose
        if output.stiffness:
            stiffness = dict(self.stiffness)
            for object_id, k in output.stiffness.items():
                self._all_bodies[object_id] = replace(self._body(object_id), stiffness_n_per_m=k)
                if k == self.scene.object(object_id).material.stiffness_n_per_m:
                    stiffness.pop(object_id, None)
                else:
                    stiffness[object_id] = k
            self.stiffness = stiffness
        if output.haptic:
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
        self.bodies = [b for b in self._all_bodies.values() if b.id not in self.haptic]
        for tool in self.tools:
            tool.forget_fixed_point()  # the fixed point may have moved with the bodies

    def _body(self, object_id: str):
        try:
            return self._all_bodies[object_id]
        except KeyError:
            raise KeyError(f"scenario changes {object_id!r}, which is not a haptic object of scene "
                           f"{self.scene.name!r}") from None
