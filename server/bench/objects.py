"""`viestac bench objects`: the god-object's cost per tick against the number of objects in the scene.

A cluttered table: the ground and N primitives (spheres, boxes, cylinders, cones, domes of 5-10
cm, at random poses) at a constant density, so the table grows with N and the hand always has
the same few objects near it. One fixed path of 1 kHz samples: a free sweep over the table, a
descent onto the object at the centre, a stroke on it, a lift. Timed per tick (perf_counter_ns,
garbage collector off) for the compiled god-object (the server's), the same with its broad phase
off (every body evaluated at the proxy each tick, as the reference does), and the Python
reference; free ticks and contact ticks apart. Written: objects.json and objects.png/.svg.

The second axis, tools (1 to 10 fingertips in contact on the contact-angle dome: the whole
loop tick and the god-objects alone; server/bench/tools_axis.py), goes into the same JSON under
"tools" and is charted in tools.png/.svg.
"""

from __future__ import annotations

import gc
import json
import math
import time
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from server.analysis.figures import save
from server.bench.machine import machine_info
from server.bench.tools_axis import run_tools_axis
from server.core.haptics.compiled import COMPILED
from server.core.haptics.god_object import ReferenceGodObject
from server.core.haptics.primitives import Body, Box, Cone, Cylinder, Hemisphere, Plane, Pose, Sphere

COUNTS = (1, 3, 10, 30, 100, 300, 1000)
QUICK_COUNTS = (1, 10, 100, 1000)
RADIUS = 0.06  # the thesis scenes' fingertip proxy
DENSITY = 8.0  # objects per square scene unit (a cluttered table)
REFERENCE_MAX = 300  # the reference costs ~N µs a tick: above this it is timed on a shorter path
KINDS = (Sphere(0.04), Box((0.08, 0.06, 0.05)), Cylinder(0.03, 0.1), Cone(0.05, 0.08), Hemisphere(0.05))


def cluttered_scene(n: int, seed: int = 0) -> list[Body]:
    """The ground and n primitives: b0 at the origin (the one the path touches), the others at
    random poses over a table of n / DENSITY square units, none within 0.3 of b0."""
    rng = np.random.default_rng(seed)
    half = 0.5 * max(1.0, math.sqrt(n / DENSITY))
    bodies = [Body("ground", Plane((2 * half + 1.0, 2 * half + 1.0))), Body("b0", Box((0.1, 0.1, 0.1)),
                                                                          Pose((0.0, 0.0, 0.05)))]
    i = 1
    while len(bodies) < n + 1:
        x, y = (float(v) for v in rng.uniform(-half, half, size=2))
        if math.hypot(x, y) < 0.3:
            continue
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        bodies.append(Body(f"b{i}", KINDS[i % len(KINDS)], Pose((x, y, float(rng.uniform(0.0, 0.08))),
                                                                tuple(q.tolist()))))
        i += 1
    return bodies


def path(reduced: bool = False) -> list[tuple[float, float, float]]:
    """Free sweep at hand height, descent onto b0's top, a stroke 1 cm deep on it, a lift."""
    top = 0.1 + RADIUS
    hips = [(-0.6 + 1.2 * i / 499, 0.25 * math.sin(i / 80), 0.4) for i in range(500)]  # free
    x0, y0 = hips[-1][0], hips[-1][1]
    hips += [(x0 * (1 - s), y0 * (1 - s), 0.4 - (0.4 - top + 0.01) * s) for s in (i / 299 for i in range(300))]
    hips += [(0.02 * math.sin(i / 100), 0.02 * (1 - math.cos(i / 100)), top - 0.01) for i in range(1000)]
    hips += [(hips[-1][0], hips[-1][1], top - 0.01 + 0.3 * i / 199) for i in range(200)]
    return hips[::4] if reduced else hips


def _time(god, bodies, hips) -> tuple[list[float], list[bool]]:
    for hip in hips[:100]:  # warm up
        god.step(bodies, hip)
    god.forget()
    costs, contact = [], []
    clock = time.perf_counter_ns
    gc.collect()
    gc.disable()
    try:
        for hip in hips:
            t0 = clock()
            s = god.step(bodies, hip)
            costs.append((clock() - t0) / 1000.0)
            contact.append(bool(s.contacts))
    finally:
        gc.enable()
    return costs, contact


def _stats(costs: list[float], contact: list[bool], want: bool) -> dict:
    xs = [c for c, k in zip(costs, contact) if k == want]
    if not xs:
        return {"ticks": 0}
    return {"ticks": len(xs), "p50_us": round(float(np.percentile(xs, 50)), 3),
            "p99_us": round(float(np.percentile(xs, 99)), 3)}


def methods() -> dict:
    out = {"reference": lambda: ReferenceGodObject(RADIUS)}
    if COMPILED:
        from server.core.haptics.god_object import CompiledGodObject

        def no_broad():
            g = CompiledGodObject(RADIUS)
            g._core.broad_phase = False
            return g
        out = {"compiled": lambda: CompiledGodObject(RADIUS), "compiled, no broad phase": no_broad, **out}
    return out


def run_objects_bench(out: Path, quick: bool = False) -> dict:
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} exists and is not a directory")
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    rows = []
    for n in QUICK_COUNTS if quick else COUNTS:
        bodies = cluttered_scene(n)
        row: dict = {"objects": n, "methods": {}}
        for label, make in methods().items():
            hips = path(reduced=(label == "reference" and (quick or n > REFERENCE_MAX)))
            costs, contact = _time(make(), bodies, hips)
            row["methods"][label] = {"free": _stats(costs, contact, False), "contact": _stats(costs, contact, True)}
        rows.append(row)
    tools = run_tools_axis(quick)
    result = {"bench": "objects", "quick": quick, "compiled": COMPILED, "machine": machine_info(),
              "proxy_radius": RADIUS, "density_per_unit2": DENSITY, "rows": rows, "tools": tools,
              "wall_s": round(time.perf_counter() - started, 1)}
    (out / "objects.json").write_text(json.dumps(result, indent=1))
    paths = chart(result, out)
    tools_paths = chart_tools(result, out)
    summary: dict = {"wall_s": result["wall_s"], "compiled core": COMPILED}
    for row in rows:
        for label, m in row["methods"].items():
            summary[f"{row['objects']} objects, {label}: free / contact p50 µs"] = (
                f"{m['free'].get('p50_us')} / {m['contact'].get('p50_us')}")
    for row in tools:
        summary[f"{row['tools']} tools: tick p50 / p99 µs, sample every 8th tick | every tick"] = (
            f"{row['sample_every_8']['tick']['p50_us']} / {row['sample_every_8']['tick']['p99_us']} | "
            f"{row['sample_every_tick']['tick']['p50_us']} / {row['sample_every_tick']['tick']['p99_us']}")
    summary["json"] = str(out / "objects.json")
    summary["chart"] = str(paths["png"])
    summary["tools chart"] = str(tools_paths["png"])
    return summary


STYLE = {"compiled": ("#2ca02c", "o"), "compiled, no broad phase": ("#9467bd", "s"), "reference": ("#7f7f7f", "^")}


def chart(result: dict, out: Path) -> dict[str, Path]:
    fig = Figure(figsize=(12.0, 4.6), layout="constrained")
    for ax, phase in zip(fig.subplots(1, 2), ("free", "contact")):
        for label, (colour, marker) in STYLE.items():
            pts = [(r["objects"], r["methods"][label][phase]) for r in result["rows"] if label in r["methods"]]
            pts = [(n, s) for n, s in pts if s["ticks"]]
            if not pts:
                continue
            xs = [n for n, _ in pts]
            ax.plot(xs, [s["p50_us"] for _, s in pts], marker=marker, color=colour, label=f"{label} p50")
            ax.plot(xs, [s["p99_us"] for _, s in pts], marker=marker, color=colour, ls=":", alpha=0.6,
                    label=f"{label} p99")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("primitives in the scene (plus the ground)")
        ax.set_ylabel("god-object step, µs per tick")
        ax.set_title(f"{phase} ticks")
        ax.grid(True, which="both", alpha=0.2)
        ax.legend(fontsize=8)
    fig.suptitle("Cost per tick against the number of objects (cluttered table, constant density; "
                 f"{'quick' if result['quick'] else 'full'})")
    return save(fig, out, "objects")


TOOL_SERIES = (("sample_every_tick", "tick", "whole tick, a sample every tick", "#d62728", "o"),
               ("sample_every_8", "tick", "whole tick, a sample every 8th tick (120 Hz)", "#1f77b4", "s"),
               ("sample_every_tick", "god_object", "god-objects alone", "#2ca02c", "^"))


def chart_tools(result: dict, out: Path) -> dict[str, Path]:
    fig = Figure(figsize=(7.0, 4.6), layout="constrained")
    ax = fig.subplots()
    xs = [r["tools"] for r in result["tools"]]
    for rate, part, label, colour, marker in TOOL_SERIES:
        ax.plot(xs, [r[rate][part]["p50_us"] for r in result["tools"]], marker=marker, color=colour, label=f"{label} p50")
        ax.plot(xs, [r[rate][part]["p99_us"] for r in result["tools"]], marker=marker, color=colour, ls=":", alpha=0.6,
                label=f"{label} p99")
    ax.set_yscale("log")
    ax.set_xticks(xs)
    ax.set_xlabel("tools (fingertips in contact)")
    ax.set_ylabel("µs per tick (in-process, warm)")
    ax.grid(True, which="both", alpha=0.2)
    ax.legend(fontsize=7)
    fig.suptitle(f"Cost per tick against the number of tools (contact-angle dome; {'quick' if result['quick'] else 'full'})")
    return save(fig, out, "tools")