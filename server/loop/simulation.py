"""One tick of the haptic simulation, with no I/O (MuJoCo's mj_step for ViESTac).

Pipeline per tick: latest tracker sample (held between samples: zero-order hold) → god-object
proxy against the scene's analytic bodies → debounced contact (hysteresis gate, for
vibration-only devices) → scenario step → device-independent cues. Time is the tick counter
(t = tick / tick_hz), never a clock read, so the same inputs give the same outputs whether the
loop runs in real time, on a virtual clock, or replays a recorded trajectory.
"""

from __future__ import annotations

from dataclasses import dataclass

from devices.cues import Cue
from scenarios.base import Scenario, ScenarioOutput, TickContext
from server.haptics.contact_gate import ContactGate
from server.haptics.god_object import Contact, GodObject
from server.haptics.primitives import Pose
from server.haptics.vec import Vec3
from server.scene import Scene


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
    poses_changed: bool      # some object moved this tick


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
        self.bodies = list(self.scene.bodies())
        self._body_slot = {b.id: i for i, b in enumerate(self.bodies)}
        self.moved: dict[str, Pose] = {}  # objects whose pose differs from the scene's
        self.tick = 0
        self.hip: Vec3 = home_position(self.scene)
        self.cues: tuple[Cue, ...] = ()
        self.refusals: tuple[str, ...] = ()  # reported by the hub's device manager
        self._settled = None  # (hip, ProxyStep) of a verified fixed point; reused while nothing moves
        self._last_step = None
        scenario.reset(seed)

    def set_hip(self, position: Vec3) -> None:
        """Latest tracker sample; applied at the next step (parameters change between ticks only)."""
        self.hip = position

    def input(self, key: str, action: str) -> None:
        self.scenario.on_input(key, action)

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
        hip = self.hip
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
        ctx = TickContext(tick, t_s, hip, proxy_step.proxy, contact, touching, nearest, self.refusals)
        output = self.scenario.step(ctx)
        poses_changed = False
        for object_id, pose in output.poses.items():
            self._settled = self._last_step = None
            slot = self._body_slot.get(object_id)
            if slot is not None:
                self.bodies[slot] = self.scene.object(object_id).body(pose)
            self.moved[object_id] = pose
            poses_changed = True
        cues_changed = output.cues != self.cues
        self.cues = output.cues
        self.tick = tick + 1
        return TickResult(tick, t_s, hip, proxy_step.proxy, proxy_step.force, contacts, contact,
                          output, cues_changed, poses_changed)
