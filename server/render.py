"""Offline rendering of a recorded HIP trajectory through a scene, on the virtual clock.

`viestac render --scene NAME|FILE.json --trajectory IN.csv --out OUT.csv`: the trajectory has
columns t,x,y,z (seconds, scene units; extra columns are ignored). The loop runs tick by tick
from the first to the last sample; between samples the HIP holds the latest one (zero-order
hold, the same rule as the live loop), so a re-render matches what the live server computed.
The ticks are the live loop's (LoopCore.tick): each new sample goes in as a tracker record, and
one output row per tick (proxy, force, contacts and cues) comes from the tick's output. A tick
that fails stops the render with the scenario's error (offline there is nothing to keep safe).
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

from server.core.cues import cue_to_wire
from scenarios import registry
from scenarios.free import FreeExploration
from server.loop.core import LoopCore
from server.loop.simulation import Simulation
from server.core.scene import Scene

SOURCE = "render"  # the tracker source of the trajectory's samples

OUT_COLUMNS = ["t", "tick", "hip_x", "hip_y", "hip_z", "proxy_x", "proxy_y", "proxy_z",
               "force_x", "force_y", "force_z", "contact", "touching", "cues", "values"]


class TrajectoryError(ValueError):
    pass


def read_trajectory(path: str | Path) -> list[tuple[float, float, float, float]]:
    rows = []
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        missing = {"t", "x", "y", "z"} - set(reader.fieldnames or [])
        if missing:
            raise TrajectoryError(f"{path}: missing column(s) {', '.join(sorted(missing))}; need t,x,y,z")
        for line, row in enumerate(reader, start=2):
            try:
                values = tuple(float(row[k]) for k in ("t", "x", "y", "z"))
            except (TypeError, ValueError):
                raise TrajectoryError(f"{path}:{line}: t,x,y,z must be numbers") from None
            if not all(math.isfinite(v) for v in values):
                raise TrajectoryError(f"{path}:{line}: NaN or Infinity")
            if rows and values[0] < rows[-1][0]:
                raise TrajectoryError(f"{path}:{line}: time goes backwards ({values[0]} < {rows[-1][0]})")
            rows.append(values)
    if not rows:
        raise TrajectoryError(f"{path}: no samples")
    return rows


def make_simulation(scene_arg: str, tick_hz: int = 1000) -> Simulation:
    if scene_arg.endswith(".json") or Path(scene_arg).is_file():
        return Simulation(FreeExploration(Scene.load(scene_arg)), tick_hz=tick_hz)
    return Simulation(registry.create(scene_arg), tick_hz=tick_hz)


def render(sim: Simulation, samples, out_path: str | Path) -> int:
    """Run the samples through `sim`; write one row per tick; return the number of ticks."""
    t0, t_end = samples[0][0], samples[-1][0]
    n_ticks = int(math.floor((t_end - t0) * sim.tick_hz + 1e-9)) + 1
    core = LoopCore(sim)
    tick_ns = 1_000_000_000 / sim.tick_hz
    index, fed = 0, -1
    with open(out_path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(OUT_COLUMNS)
        for _ in range(n_ticks):
            tick = core.sim.tick
            t = t0 + tick / sim.tick_hz
            while index + 1 < len(samples) and samples[index + 1][0] <= t + 1e-12:
                index += 1
            now_ns = round(tick * tick_ns)
            records = ()
            if index != fed:  # a new sample: the HIP holds it until the next one
                fed = index
                records = (["tracker", SOURCE, index, samples[index][0] * 1000.0, list(samples[index][1:]), None,
                            now_ns],)
            out = core.tick(records, now_ns)
            r = out.result
            if r is None:
                raise RuntimeError(f"tick {out.tick} failed: {out.error}")
            writer.writerow([f"{t:.6f}", r.tick, *(f"{v:.9f}" for v in r.hip), *(f"{v:.9f}" for v in r.proxy),
                             *(f"{v:.6f}" for v in r.force), int(r.contact),
                             ";".join(sorted({c.body_id for c in r.contacts})),
                             json.dumps([cue_to_wire(c) for c in r.output.cues], separators=(",", ":")),
                             json.dumps(r.output.values, separators=(",", ":"))])
    return n_ticks
