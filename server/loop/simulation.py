"""One tick of the haptic simulation, with no I/O (MuJoCo's mj_step for ViESTac).

Pipeline per tick: latest tracker sample (held between samples: zero-order hold; or the point
the scenario holds the HIP at, for the experimenter's "tap") → god-object proxy against the
scene's analytic bodies → debounced contact (hysteresis gate, for vibration-only devices) →
scenario step → device-independent cues, plus the scenario's changes to its objects (poses,
visibility, touchability, stiffness), applied for the next tick. Time is the tick counter
(t = tick / tick_hz), never a clock read, so the same inputs give the same outputs whether the
loop runs in real time, on a virtual clock, or replays a recorded trajectory.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from server.core.cues import Cue
from server.core.scenario import Scenario, ScenarioOutput, TickContext, Trial
from server.core.haptics.contact_gate import ContactGate
from server.core.haptics.god_object import Contact, GodObject
from server.core.haptics.primitives import Pose
from server.core.haptics.vec import Vec3
from server.core.scene import Scene


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
    scene_changed: bool      # an object moved, appeared, vanished or changed stiffness this tick


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
        self.gate = gate if gate is not None else ContactGate()
        self.god = GodObject(self.scene.proxy_radius)
        self._all_bodies = {b.id: b for b in self.scene.bodies()}
        self.bodies = list(self._all_bodies.values())  # the touchable ones, in scene order
        self.moved: dict[str, Pose] = {}  # objects whose pose differs from the scene's
        self.visibility: dict[str, bool] = {}  # objects/overlays shown or hidden against the scene
        self.scales: dict[str, tuple[float, float, float]] = {}  # objects drawn scaled (never touched scaled)
        self.untouchable: set[str] = set()
        self.tick = 0
        self.hip: Vec3 = home_position(self.scene)
        self.held: Vec3 | None = None  # where the scenario holds the HIP, overriding the tracker
        self.cues: tuple[Cue, ...] = ()
        self.refusals: tuple[str, ...] = ()  # reported by the device host, through the hub
        self.events: list[dict] = []  # scenario events not yet published, stamped with their tick
        self.trial: Trial | None = None
        self._settled = None  # (hip, ProxyStep) of a verified fixed point; reused while nothing moves
        self._last_step = None
        scenario.reset(seed)

    def set_hip(self, position: Vec3) -> None:
        """Latest tracker sample; applied at the next step (parameters change between ticks only)."""
        self.hip = position

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
        hip = self.held if self.held is not None else self.hip
        settled = self._settled
        if settled is not None and settled[0] == hip:
            # The HIP is held between tracker samples (~8 ticks per 120 Hz sample) and nothing
            # moved; the last step reproduced the one before it for this HIP, so it is a fixed
            # point of the (deterministic) god-object: reuse it instead of recomputing.
            proxy_step = settled[1]
        else:
            proxy_step = self.god.step(self.bodies, hip)
            last = self._last_step
            fixed = (last is not None and last[0] == hip and last[1].proxy == proxy_step.proxy
                     and last[1].contacts == proxy_step.contacts)
            self._settled = (hip, proxy_step) if fixed else None
            self._last_step = (hip, proxy_step)
        contacts = proxy_step.contacts
        contact = self.gate.update(t_s, bool(contacts), proxy_step.separation)
        touching = frozenset(c.body_id for c in contacts)
        nearest = self._nearest_body(hip) if contact else None
        ctx = TickContext(tick, t_s, hip, proxy_step.proxy, contact, touching, nearest, self.refusals,
                          self.god.sticking)
        output = self.scenario.step(ctx)
        scene_changed = False
        if output.poses or output.haptic or output.stiffness or output.visible or output.scales:
            scene_changed = self._apply_changes(output)
        if output.hold_hip != self.held:
            if output.hold_hip is not None:
                # A tap lands from outside: put the proxy on the surface nearest the held point
                # instead of dragging it there from wherever the tracker left it.
                self.god.reset(output.hold_hip, self.bodies)
            self._settled = self._last_step = None
            self.held = output.hold_hip
        if output.events:
            self.events.extend({"tick": tick, "t": t_s, **event} for event in output.events)
        cues_changed = output.cues != self.cues
        self.cues = output.cues
        self.tick = tick + 1
        return TickResult(tick, t_s, hip, proxy_step.proxy, proxy_step.force, contacts, contact,
                          output, cues_changed, scene_changed)

    def _apply_changes(self, output: ScenarioOutput) -> bool:
        for object_id, pose in output.poses.items():
            if object_id in self._all_bodies:
                self._all_bodies[object_id] = replace(self._all_bodies[object_id], pose=pose)
            elif not self.scene.has_id(object_id):  # drawn-only objects move too, they just have no body
                raise KeyError(f"scenario moves {object_id!r}, which is not in scene {self.scene.name!r}")
            self.moved[object_id] = pose
        for object_id, k in output.stiffness.items():
            self._all_bodies[object_id] = replace(self._body(object_id), stiffness_n_per_m=k)
        for object_id, on in output.haptic.items():
            self._body(object_id)
            (self.untouchable.discard if on else self.untouchable.add)(object_id)
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
        self.bodies = [b for b in self._all_bodies.values() if b.id not in self.untouchable]
        self._settled = self._last_step = None  # the fixed point may have moved with the bodies
        return True

    def _body(self, object_id: str):
        try:
            return self._all_bodies[object_id]
        except KeyError:
            raise KeyError(f"scenario changes {object_id!r}, which is not a haptic object of scene "
                           f"{self.scene.name!r}") from None
