"""The scenario interface: one small contract for every virtual task (Gymnasium-like).

A scenario builds its static Scene once, then is stepped by the loop every tick with a read-only
TickContext (what the haptic renderer found) and answers with device-independent cues, HUD text,
values worth showing or recording, and poses of objects it moved. It does no I/O and reads no
clock: time comes in the context, so a study replays identically on the virtual clock.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

from devices.cues import Cue
from server.haptics.primitives import Pose
from server.haptics.vec import Vec3
from server.scene import Scene


@dataclass(frozen=True)
class TickContext:
    tick: int              # loop tick counter
    t_s: float             # simulation time = tick / tick_hz, seconds
    hip: Vec3              # tracked HIP, scene frame
    proxy: Vec3            # god-object proxy
    contact: bool          # debounced contact (hysteresis gate)
    touching: frozenset[str]  # bodies the proxy touches this tick (raw)
    nearest: str | None    # haptic body nearest to the HIP
    refusals: tuple[str, ...] = ()  # cues a connected device refused, with reasons (devices.encoder)


@dataclass(frozen=True)
class ScenarioOutput:
    cues: tuple[Cue, ...] = ()
    hud: str = ""
    values: dict = field(default_factory=dict)
    poses: dict[str, Pose] = field(default_factory=dict)  # objects moved this tick


class Scenario(Protocol):
    id: str      # versioned id, e.g. "contact-angle-v1"
    title: str

    def build_scene(self) -> Scene: ...

    def reset(self, seed: int) -> None: ...

    def step(self, ctx: TickContext) -> ScenarioOutput: ...

    def on_input(self, key: str, action: str) -> None: ...
