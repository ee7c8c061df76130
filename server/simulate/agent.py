"""A synthetic participant for the positioning task: closed loop, minimum-jerk submovements,
depth from touch only.

What it may use is what a participant has: the side view (an object's and the arrow's y and z:
the orthographic camera hides x), the HUD text, and the fingertip's feel of the device
(virtual_device.Feel: pulse onsets, continuous vibration, silence, the magnet's tilt). It never
reads an object's x. What it knows beforehand is what the training taught: how the condition's
cue relates to distance ("faster when closer", "slower when closer"; the FerroVibe's tilt points
where to go, its pulse rate rises with height error shrinking).

Movements are minimum-jerk submovements (Flash & Hogan 1985: x(τ) = x0 + (x1 − x0)(10τ³ −
15τ⁴ + 6τ⁵)), each followed by a dwell to feel the cue. Depth is found by a step search: step,
feel, keep going while the cue says "closer", otherwise turn and halve the step; "at the
target" is the HUD's hold count-down, which the scenario shows only within 0.05 on every axis.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from scenarios.positioning import ITEMS
from server.core.tool import DEFAULT_PROXY_RADIUS
from server.simulate.virtual_device import Feel
from server.simulate.virtual_hub import VirtualHub

ITEM = {item.id: item for item in ITEMS}
PROXY = DEFAULT_PROXY_RADIUS    # the fingertip sphere: a carried object hangs half + this below it
ARROW_GAP = 0.04 + 0.12        # arrow head centre above the target object's top (scenarios/positioning.py)
SLOWER_WHEN_CLOSER = ("none-at-target",)


@dataclass(frozen=True)
class AgentParams:
    submovement_s: float = 0.35     # duration of one minimum-jerk submovement
    first_step: float = 0.4         # depth search: first step (scene units)
    min_step: float = 0.02
    feel_timeout_s: float = 2.3     # waiting for two fresh pulse onsets (periods up to 1.05 s)
    trial_timeout_s: float = 90.0   # gives up (the experimenter aborts) after this
    endpoint_noise: float = 0.05    # motor noise: SD of the gain along the movement (ours)
    duration_jitter: float = 0.2    # submovement durations vary by this fraction (SD, ours)
    duration_scale: float = 1.0     # every movement takes this many times as long: a slower participant, or
    #                                 (per device, docs/synthetic.md "Effect settings") a device that slows one down

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"agent.{f.name} must be a finite number, got {value!r}")
            if value < 0 or (value == 0 and f.name not in NON_NEGATIVE):
                raise ValueError(f"agent.{f.name} must be {'>= 0' if f.name in NON_NEGATIVE else '> 0'}, got {value!r}")


NON_NEGATIVE = ("endpoint_noise", "duration_jitter")  # noise may be off; durations and steps may not be 0


def min_jerk(a, b, tau: float):
    s = 10 * tau ** 3 - 15 * tau ** 4 + 6 * tau ** 5
    return (a[0] + (b[0] - a[0]) * s, a[1] + (b[1] - a[1]) * s, a[2] + (b[2] - a[2]) * s)


class GaveUp(Exception):
    """The agent did not complete the trial in time."""


class PositioningAgent:
    def __init__(self, hub: VirtualHub, feel: Feel, params: AgentParams = AgentParams(), rng=None):
        """`rng` (numpy Generator): motor noise of this participant and trial; None = noiseless."""
        self.hub, self.feel, self.p, self.rng = hub, feel, params, rng
        self.hip = (0.0, 0.0, 2.0)
        self.deadline = 0.0
        self.reached_x: float | None = None  # where the count-down was last seen (remembered)
        self.aim = (0.0, 2.0)                # the fingertip's y and z that put the object under the arrow

    # -- the senses -----------------------------------------------------------------------------
    def hud(self) -> str:
        return (self.hub.last_state or {}).get("hud", "")

    def seen(self, object_id: str) -> tuple[float, float]:
        """(y, z) of an object as the side view shows it."""
        pose = self.hub.core.sim.data.moved.get(object_id) or self.hub.core.sim.scene.object(object_id).pose
        return pose.pos[1], pose.pos[2]

    # -- the body -------------------------------------------------------------------------------
    def move(self, target, duration_s: float | None = None, stop_when=None) -> None:
        """One minimum-jerk submovement; `stop_when` (checked every tick) halts it early, as a
        participant stops the moment the hold count-down appears."""
        duration_s = (duration_s or self.p.submovement_s) * self.p.duration_scale
        if self.rng is not None:
            # no two reaches are alike: mostly a gain error along the movement (aimed movements
            # scatter along their direction more than across it), plus a small scatter across
            gain = 1.0 + self.rng.normal(0.0, self.p.endpoint_noise)
            target = tuple(a + (b - a) * gain + self.rng.normal(0.0, 0.003) for a, b in zip(self.hip, target))
            duration_s *= max(0.5, 1.0 + self.rng.normal(0.0, self.p.duration_jitter))
        start, n = self.hip, max(1, round(duration_s * self.hub.tick_hz))
        for k in range(1, n + 1):
            self.hip = min_jerk(start, target, k / n)
            self.hub.set_hip(self.hip)
            self.hub.advance()
            if stop_when is not None and stop_when():
                break
        self._check_time()

    def dwell(self, seconds: float) -> None:
        self.hub.set_hip(self.hip)
        self.hub.advance_s(seconds)
        self._check_time()

    def _check_time(self) -> None:
        if self.hub.t_s > self.deadline:
            raise GaveUp(f"no insertion after {self.p.trial_timeout_s:.0f} s")

    def wait_for(self, predicate, timeout_s: float) -> bool:
        end = self.hub.t_s + timeout_s
        while self.hub.t_s < end:
            if predicate():
                return True
            self.dwell(0.01)
        return predicate()

    # -- the task -------------------------------------------------------------------------------
    def run_trial(self, object_id: str, cue: str) -> None:
        """Pick, place at the target, hold until GO, insert. Raises GaveUp on a timeout."""
        self.deadline = self.hub.t_s + self.p.trial_timeout_s
        item = ITEM[object_id]
        self.dwell(0.1)  # look first: the new trial's scene (objects back at their starts) is drawn
        self.grasp(item)
        head_y, head_z = self.seen("arrow_head")
        target_z = head_z - ARROW_GAP - item.half
        hang = item.half + PROXY
        self.move((self.hip[0], self.hip[1], target_z + hang + 0.4), 0.5)  # lift clear of everything
        self.move((self.hip[0], head_y, target_z + hang + 0.4), 0.8)
        self.aim = (head_y, target_z + hang)  # where sight puts the fingertip in y and z
        self.move((self.hip[0], *self.aim), 0.5)
        while True:  # left the zone before GO (the count-down restarts): search again
            if cue == "3dof":
                self.search_by_tilt()
            else:
                self.search_depth(slower_when_closer=cue in SLOWER_WHEN_CLOSER)
            if self.wait_for(lambda: self.hud() == "GO" or not self.at_target(), 3.0) and self.hud() == "GO":
                break
        hole_y, hole_top = self.seen(f"{object_id}_hole")[0], item.hole.height
        # straight down, pressing into the rim: the fingertip comes to rest on it, the object inside
        self.move((self.hip[0], hole_y, hole_top - 0.05), 0.6)
        if not self.wait_for(lambda: self.hud().startswith("Done"), 1.0):
            raise GaveUp("not inserted")
        self.move((self.hip[0], self.hip[1], 2.0), 0.4)

    def grasp(self, item) -> None:
        """The object's depth is unseen: come down beside the table's far end at the object's
        height and sweep through depth until it is grasped; sweep back once if it was missed."""
        y, z = self.seen(item.id)
        self.move((self.hip[0], self.hip[1], 1.6), 0.4)  # up first: never drag through the scene
        for x0, x1 in ((-1.45, 1.45), (1.45, -1.45)):
            self.move((x0, y, 1.6), 0.6)
            self.move((x0, y, z), 0.4)
            self.move((x1, y, z), 2.5)
            if self.wait_for(lambda: self.hud() == "Bring it to the arrow", 0.2):
                return
            self.move((x1, y, 1.6), 0.4)
        raise GaveUp("could not find the object")

    def at_target(self) -> bool:
        return self.hud().startswith("Hold") or self.hud() == "GO"

    def feel_interval(self) -> float | None:
        """Hold still and feel: the onset interval of two fresh pulses, 0 for a vibration that
        stays on for 0.35 s after stopping (while the finger moves, every new cue value restarts
        the burst, so the vibration feels continuous then), None for nothing felt."""
        start_t, start_n = self.hub.t_s, self.feel.onsets()

        def steady_on() -> bool:
            c = self.feel.channels[0]
            return c.on and c.since_s <= start_t and self.hub.t_s - start_t >= 0.35

        self.wait_for(lambda: self.feel.onsets() >= start_n + 2 or steady_on() or self.at_target(),
                      self.p.feel_timeout_s)
        if steady_on():
            return 0.0
        if self.feel.onsets() < start_n + 2:
            return None
        return self.feel.pulse_interval_s(self.hub.t_s)

    def search_depth(self, slower_when_closer: bool) -> None:
        """Step search on the pulse interval (1-DoF cue)."""
        step, direction = self.p.first_step, 1.0
        last = self.feel_interval()
        while last is None and not self.at_target():  # outside the cue zone: look for it
            self.explore()
            last = self.feel_interval()
        while not self.at_target():
            x = max(-1.5, min(1.5, self.hip[0] + direction * step))
            self.move((x, *self.aim), stop_when=self.at_target)
            if self.at_target():
                self.centre(direction)
                break
            now = self.feel_interval()
            if now is None:  # left the cue zone (or P3/P4 beyond their offset): look for it again
                direction = self.explore()  # ... and keep going the way that found it
                last = self.feel_interval()
                continue
            closer = last is None or (now > last if slower_when_closer else now < last)
            if not closer:
                direction, step = -direction, max(self.p.min_step, step / 2)
            last = now

    def explore(self) -> float:
        """Nothing felt: outside the cue zone. Move through depth toward the table's middle
        and beyond, as a participant sweeps until the device answers; returns the way it went."""
        x = self.hip[0]
        if self.reached_x is not None:  # it was there a moment ago: go back to where it was
            way = 1.0 if self.reached_x >= x else -1.0
            self.move((self.reached_x, *self.aim), stop_when=self.at_target)
            return way
        self._sweep = getattr(self, "_sweep", -1.0 if x > 0 else 1.0)
        if abs(x + self._sweep * self.p.first_step) > 1.5:
            self._sweep = -self._sweep
        self.move((x + self._sweep * self.p.first_step, *self.aim), stop_when=self.at_target)
        return self._sweep

    def centre(self, direction: float) -> None:
        """Bracketing: the count-down appeared at the zone's edge; creep on until it vanishes,
        then settle halfway between where it appeared and where it went."""
        enter = self.reached_x = self.hip[0]
        self.move((enter + direction * 0.15, *self.aim), 1.2, stop_when=lambda: not self.at_target())
        leave = self.hip[0]
        self.reached_x = (enter + leave) / 2
        self.move((self.reached_x, *self.aim), 0.4)

    def search_by_tilt(self) -> None:
        """The FerroVibe points the way: its tilt's front/back component says where the depth
        target is (180° = in front, away from the viewer: −x; 0° = overshot: +x)."""
        step = self.p.first_step
        previous = None
        while not self.at_target():
            self.dwell(0.15)
            direction, magnitude = self.feel.tilt()
            if magnitude == 0:  # flat: at the target, or outside the cue zone
                if self.wait_for(self.at_target, 0.5):
                    break
                self.explore()
                continue
            front_back = math.cos(math.radians(direction))  # −1 at 180° (go −x), +1 at 0° (go +x)
            dx = -1.0 if front_back < -0.5 else (1.0 if front_back > 0.5 else 0.0)
            if dx == 0.0:
                self.dwell(0.2)  # pure left/right tilt: depth is right; y and z were set by sight
                continue
            if previous is not None and dx != previous:
                step = max(self.p.min_step, step / 2)
            previous = dx
            self.move((max(-1.5, min(1.5, self.hip[0] + dx * step)), *self.aim), stop_when=self.at_target)
            if self.at_target():
                self.centre(dx)
                break
