"""Offline rendering of a recorded HIP trajectory through a scene, on the virtual clock.

`viestac render --scene NAME|FILE.json --trajectory IN.csv --out OUT.csv [--tool POINT ...]`:
the trajectory has columns t,x,y,z (seconds, scene units; extra columns are ignored): the primary
point, the HIP; an exported trial's trajectory file (`t_s`, `hip_x`, `hip_y`, `hip_z`, docs/data.md)
reads as that. Or it is a multi-point CSV (server/core/records.py; what export writes for a
recording of several points): `t`, then NAME.x,NAME.y,NAME.z per point name (server/core/points.py),
a cell left empty where a point was not tracked. Each point that names a tool (the primary point,
the scenario's `fingers`, and every --tool) drives that tool, the others are the hand's drawn
points, exactly as a live tracker sample with `points`. The loop runs tick by tick
from the first to the last sample; between samples the HIP holds the latest one (zero-order
hold, the same rule as the live loop), so a re-render matches what the live server computed.
The ticks are the live loop's (Loop.tick): each new sample goes in as a tracker record, and
one output row per tick (proxy, force, contacts and cues) comes from the tick's output. A tick
that fails stops the render with the scenario's error (offline there is nothing to keep safe).
With several tools, each other tool adds NAME.proxy_x/y/z, NAME.contact and NAME.cues columns.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

from server.ipc.records import TrackerSample
from server.core.cues import cue_to_wire
from scenarios import registry
from scenarios.free import FreeExploration
from server.core.points import PRIMARY_POINT, check_point_name
from server.core.records import EXPORT_TRAJECTORY_AS_SAMPLES
from server.loop.tick import Loop
from server.loop.simulation import Simulation
from server.core.scene import Scene
from server.wire.messages import Tracker

SOURCE = "render"  # the tracker source of the trajectory's samples

OUT_COLUMNS = ["t", "tick", "hip_x", "hip_y", "hip_z", "proxy_x", "proxy_y", "proxy_z",
               "force_x", "force_y", "force_z", "contact", "touching", "cues", "values"]


class TrajectoryError(ValueError):
    pass


def read_trajectory(path: str | Path) -> list[tuple]:
    """The samples of a trajectory file: (t, x, y, z) rows of the primary point (`t,x,y,z`), or
    (t, {point: (x, y, z)}) rows of a multi-point CSV (module doc)."""
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader, None) or []
        if not {"t", "x", "y", "z"} <= set(header) and "t" in header and any("." in c for c in header):
            return _read_points(path, header, reader)
        f.seek(0)
        return _read_single(path, csv.DictReader(f))


def _read_single(path, reader: csv.DictReader) -> list[tuple[float, float, float, float]]:
    rows = []
    names = set(reader.fieldnames or [])
    keys = {k: k for k in "txyz"}
    if not set(keys) <= names and set(EXPORT_TRAJECTORY_AS_SAMPLES.values()) <= names:
        keys = EXPORT_TRAJECTORY_AS_SAMPLES  # an exported trial's trajectory file: the HIP as recorded
    missing = set(keys.values()) - names
    if missing:
        raise TrajectoryError(f"{path}: missing column(s) {', '.join(sorted(missing))}; need t,x,y,z "
                              "(or t and NAME.x,NAME.y,NAME.z per point, or an exported trajectory file)")
    for line, row in enumerate(reader, start=2):
        try:
            values = tuple(float(row[keys[k]]) for k in ("t", "x", "y", "z"))
        except (TypeError, ValueError):
            raise TrajectoryError(f"{path}:{line}: t,x,y,z must be numbers") from None
        _check_row(path, line, values, rows)
        rows.append(values)
    if not rows:
        raise TrajectoryError(f"{path}: no samples")
    return rows


def _read_points(path, header: list[str], reader) -> list[tuple[float, dict]]:
    """A multi-point CSV: `t`, then NAME.x, NAME.y, NAME.z (a column name split at its last dot)."""
    columns: dict[str, dict[str, int]] = {}
    for index, column in enumerate(header):
        if column == "t":
            continue
        name, dot, axis = column.rpartition(".")
        if not dot or axis not in ("x", "y", "z"):
            raise TrajectoryError(f"{path}: column {column!r} is not NAME.x, NAME.y or NAME.z")
        try:
            check_point_name(name)
        except ValueError as exc:
            raise TrajectoryError(f"{path}: column {column!r}: {exc}") from None
        columns.setdefault(name, {})[axis] = index
    incomplete = sorted(name for name, axes in columns.items() if len(axes) != 3)
    if incomplete:
        raise TrajectoryError(f"{path}: point(s) {', '.join(incomplete)} need all of .x, .y and .z")
    t_index = header.index("t")
    rows: list[tuple[float, dict]] = []
    for line, row in enumerate(reader, start=2):
        try:
            t = float(row[t_index])
            points = {}
            for name, axes in columns.items():
                cells = [row[axes[a]].strip() for a in "xyz"]
                if any(cells):  # an empty cell: the point was not tracked in this sample
                    points[name] = tuple(float(c) for c in cells)
        except (IndexError, ValueError):
            raise TrajectoryError(f"{path}:{line}: t and every given x, y, z must be numbers") from None
        _check_row(path, line, (t, *(v for p in points.values() for v in p)), rows)
        if not points:
            raise TrajectoryError(f"{path}:{line}: no point in this sample")
        rows.append((t, points))
    if not rows:
        raise TrajectoryError(f"{path}: no samples")
    return rows


def _check_row(path, line: int, values, rows: list) -> None:
    if not all(math.isfinite(v) for v in values):
        raise TrajectoryError(f"{path}:{line}: NaN or Infinity")
    if rows and values[0] < rows[-1][0]:
        raise TrajectoryError(f"{path}:{line}: time goes backwards ({values[0]} < {rows[-1][0]})")


def make_simulation(scene_arg: str, tick_hz: int = 1000, tools: tuple[str, ...] = ()) -> Simulation:
    """The scenario (or a scene file's free exploration), with a tool for each of `tools` besides
    the primary point and what the scenario needs."""
    if scene_arg.endswith(".json") or Path(scene_arg).is_file():
        return Simulation(FreeExploration(Scene.load(scene_arg)), tick_hz=tick_hz, rig=tools)
    return Simulation(registry.create(scene_arg), tick_hz=tick_hz, rig=tools)


def _tracker_record(index: int, sample: tuple, now_ns: int) -> TrackerSample:
    """A sample as the live loop's tracker record: the primary point as `pos` (else the first
    point, named), every other point in `points`."""
    if isinstance(sample[1], dict):
        points = dict(sample[1])
        point = PRIMARY_POINT if PRIMARY_POINT in points else next(iter(points))
        pos = points.pop(point)
        return Tracker(index, sample[0] * 1000.0, pos, None, None if point == PRIMARY_POINT else point,
                       points or None).loop_record(SOURCE, now_ns)
    return TrackerSample(SOURCE, index, sample[0] * 1000.0, list(sample[1:]), None, now_ns)


def render(sim: Simulation, samples, out_path: str | Path) -> int:
    """Run the samples through `sim`; write one row per tick; return the number of ticks."""
    t0, t_end = samples[0][0], samples[-1][0]
    n_ticks = int(math.floor((t_end - t0) * sim.tick_hz + 1e-9)) + 1
    core = Loop(sim)
    tick_ns = 1_000_000_000 / sim.tick_hz
    index, fed = 0, -1
    others = [tool.name for tool in sim.data.tools[1:]]
    with open(out_path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(OUT_COLUMNS + [f"{name}.{c}" for name in others
                                       for c in ("proxy_x", "proxy_y", "proxy_z", "contact", "cues")])
        for _ in range(n_ticks):
            tick = core.sim.data.tick
            t = t0 + tick / sim.tick_hz
            while index + 1 < len(samples) and samples[index + 1][0] <= t + 1e-12:
                index += 1
            now_ns = round(tick * tick_ns)
            records = ()
            if index != fed:  # a new sample: the HIP holds it until the next one
                fed = index
                records = (_tracker_record(index, samples[index], now_ns),)
            out = core.tick(records, now_ns)
            r = out.result
            if r is None:
                raise RuntimeError(f"tick {out.tick} failed: {out.error}")
            writer.writerow([f"{t:.6f}", r.tick, *(f"{v:.9f}" for v in r.hip), *(f"{v:.9f}" for v in r.proxy),
                             *(f"{v:.6f}" for v in r.force), int(r.contact),
                             ";".join(sorted({c.body_id for c in r.contacts})),
                             json.dumps([cue_to_wire(c) for c in r.output.cues], separators=(",", ":")),
                             json.dumps(r.output.values, separators=(",", ":")),
                             *_other_tools(r)])
    return n_ticks


def _other_tools(r) -> list:
    cells: list = []
    for view in r.tools[1:]:
        cues = r.output.tool_cues.get(view.name, ())
        cells += [*(f"{v:.9f}" for v in view.proxy), int(view.contact),
                  json.dumps([cue_to_wire(c) for c in cues], separators=(",", ":"))]
    return cells
