"""A tool (CHAI3D's word): one tracked point and what renders it.

A tool owns the tracked position (the HIP: the latest applied tracker sample), the position a
scenario holds it at instead (the experimenter's "tap"), the god-object proxy and its radius, the
contact gate, and the tracker rule: which source drives it. A tool is named by the tracked point
that drives it (server/core/points.py, e.g. "right.thumb.tip"). The simulation's data
(server/loop/sim_data.py) holds a tuple of tools, one per rig point, the primary (the HIP,
"right.index.tip") first; each has its own driver and god-object, and tools do not collide with
each other.

Tracker rule (docs/protocol.md): one source drives a tool at a time. A sample is applied when the
tool has no driver, or it comes from the driver, or the driver has sent nothing for
DRIVER_QUIET_S (then the new source takes over). Samples from other sources are ignored and
counted per source. When the driver leaves (`release`) or stops sending (`lose`: its samples'
ttl passed), the tool returns home (free space), its contact gate is off at once (no dwell holds
a contact cue on) and it has no driver.

Pure: time comes in as an argument (simulation seconds), no clock is read.
"""

from __future__ import annotations

from server.core.haptics.contact_gate import ContactGate
from server.core.haptics.god_object import GodObject, ProxyStep
from server.core.haptics.primitives import Body
from server.core.haptics.vec import Vec3
from server.core.points import PRIMARY_POINT
from server.core.workspace import clamp_to_workspace, in_workspace

DEFAULT_PROXY_RADIUS = 0.06  # scene units: the fingertip sphere the scenes are built around
DRIVER_QUIET_S = 1.0         # a driver silent this long loses the tool to the next source that sends


class Tool:
    def __init__(self, home: Vec3, proxy_radius: float = DEFAULT_PROXY_RADIUS, gate: ContactGate | None = None,
                 name: str = PRIMARY_POINT):
        self.name = name                 # the point that drives it
        self.home = home
        self.tracked: Vec3 = home        # latest applied tracker sample (zero-order hold between samples)
        self.held: Vec3 | None = None    # where the scenario holds the tool, overriding the tracker
        self.god = GodObject(proxy_radius)
        self.gate = gate if gate is not None else ContactGate()
        self.driver: int | str | None = None  # the source whose samples move the tool
        self.seq: int | None = None      # seq of the driver's last applied sample
        self.ignored: dict[int | str, int] = {}  # samples refused per source (someone else drove)
        self.lost = False                # its driver's samples stopped (ttl): home until a sample arrives
        self._driver_t = 0.0             # simulation time of the driver's last applied sample
        # (hip, ProxyStep) of a verified fixed point of the god-object; reused while nothing moves
        self._settled: tuple[Vec3, ProxyStep] | None = None
        self._last_step: tuple[Vec3, ProxyStep] | None = None

    @property
    def proxy_radius(self) -> float:
        return self.god.radius

    @property
    def hip(self) -> Vec3:
        """The point rendered this tick: the held position if the scenario holds one, else the tracked one."""
        return self.held if self.held is not None else self.tracked

    # -- the tracker rule ------------------------------------------------------------------------
    def offer(self, source: int | str, seq: int, position: Vec3, t_s: float) -> bool:
        """A tracker sample from `source` at simulation time `t_s`; True when it was applied. A
        position outside the workspace is clamped to it: the wire refuses those, but a driver that
        bypasses the wire must not carry the god-object to where its arithmetic overflows."""
        driver = self.driver
        if driver is not None and source != driver and t_s - self._driver_t < DRIVER_QUIET_S:
            self.ignored[source] = self.ignored.get(source, 0) + 1
            return False
        self.driver, self.seq, self._driver_t = source, seq, t_s
        self.lost = False
        self.place(position)
        return True

    def place(self, position: Vec3) -> None:
        """Move the tracked point (no tracker rule), clamped to the workspace."""
        self.tracked = position if in_workspace(position) else clamp_to_workspace(position)

    def release(self, source: int | str) -> bool:
        """`source` is gone: if it drove the tool, the tool goes home and has no driver."""
        if self.driver is None or source != self.driver:
            return False
        self.driver = self.seq = None
        self.tracked = self.home
        # Out of contact at once: the god-object starts from home (not dragged out of a surface)
        # and the gate's minimum on-dwell does not hold a contact cue on for a finger that is gone.
        self.reset_proxy()
        self.gate.reset()
        return True

    def lose(self, source: int | str) -> bool:
        """`source` stopped sending (its samples' ttl passed): released as above, and marked lost
        until a sample moves it again."""
        if not self.release(source):
            return False
        self.lost = True
        return True

    def take_driver(self, other: Tool) -> None:
        """Keep who drives across a rebuilt simulation (a scenario switch: SimData.carry_over), not
        where it was."""
        self.driver, self.seq, self._driver_t = other.driver, other.seq, other._driver_t
        self.ignored, self.lost = other.ignored, other.lost

    # -- rendering -------------------------------------------------------------------------------
    def proxy_step(self, bodies: list[Body], hip: Vec3) -> ProxyStep:
        """The god-object's step for `hip`; a verified fixed point is reused instead of recomputed."""
        settled = self._settled
        if settled is not None and settled[0] == hip:
            # The HIP is held between tracker samples (~8 ticks per 120 Hz sample) and nothing
            # moved; the last step reproduced the one before it for this HIP, so it is a fixed
            # point of the (deterministic) god-object: reuse it instead of recomputing.
            return settled[1]
        step = self.god.step(bodies, hip)
        last = self._last_step
        fixed = (last is not None and last[0] == hip and last[1].proxy == step.proxy
                 and last[1].contacts == step.contacts)
        self._settled = (hip, step) if fixed else None
        self._last_step = (hip, step)
        return step

    def hold(self, position: Vec3 | None, bodies: list[Body]) -> None:
        """Hold the tool at `position` from the next tick on (None: back to the tracker)."""
        if position is not None:
            # A tap lands from outside: put the proxy on the surface nearest the held point
            # instead of dragging it there from wherever the tracker left it.
            self.god.reset(position, bodies)
        self.forget_fixed_point()
        self.held = position

    def reset_proxy(self) -> None:
        """Forget the god-object's state (a tick failed): the next step starts from the HIP."""
        self.god.forget()
        self.forget_fixed_point()

    def forget_fixed_point(self) -> None:
        """The bodies moved (or the proxy was placed): the last fixed point may no longer hold."""
        self._settled = self._last_step = None
