"""`viestac bench accuracy`: per-tick cost against error of every contact method, per thesis scene.

Each method (server/bench/contact_methods.py: the analytic god-object, the god-object on mesh
tessellations and on signed-distance grids, a CHAI3D-like penalty field) runs the scene's fixed
trajectory (server/bench/trajectories.py) one sample per tick. Cost: the wall time of each
``step`` (perf_counter_ns, garbage collector off). Error against the closed-form truth: proxy
position error (over the ticks where the truth or the method is in contact), force direction
error (where both are, and the truth is at least 0.5 mm deep) and the share of ticks whose contact
state is wrong. Written: accuracy.json and accuracy.png/.svg (cost against error, one point per
method × resolution, the Pareto front and the chart's choice marked).

The choice per scene: the lowest error (p99 of the proxy position) among the methods whose median
cost fits the tick budget (the median, because a p99 of a few tens of µs on a shared 2-core
machine measures preemption by other processes as much as the method); errors within TIE_MM are
equal, and then a method that cannot tunnel
(it tests the swept segment: a proxy method) goes before one that can, and the cheaper before
the dearer. The server's method is the analytic god-object; `server_follows_chart` says whether
the chart agrees.
"""

from __future__ import annotations

import gc
import json
import time
from dataclasses import replace
from math import acos, degrees, sqrt
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from scenarios.registry import SCENARIOS
from server.analysis.figures import save
from server.bench.contact_methods import REFERENCE_LABEL, ContactMethod, build_methods, reference_method
from server.bench.machine import machine_info
from server.bench.trajectories import SCENES, Trajectory, scene_trajectory
from server.core.haptics.compiled import COMPILED

BUDGET_US = 250.0  # a quarter of the 1 kHz tick: the rest is the scenario, the gate and I/O
TIE_MM = 1e-3
DEEP_MM = 0.5  # force direction is compared only this deep (shallower, the direction is noise)
FLOOR_MM = 1e-4  # errors below this are drawn at this height on the log axis
SERVER_METHOD = "analytic"
QUICK_SPEED = 4.0  # --quick runs the same paths four times faster (fewer ticks)
QUICK_SCENES = ("contact-angle-v1", "shape-v1", "positioning-v1")


def scene_bodies(scene: str):
    """The scenario's own haptic bodies, frictionless (the truth is the frictionless model)."""
    built = SCENARIOS[scene].factory().build_scene()
    bodies = [replace(b, static_friction=0.0, dynamic_friction=0.0) for b in built.bodies()]
    return bodies, built.proxy_radius


def _pct(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else 0.0


def run_method(method: ContactMethod, traj: Trajectory) -> dict:
    """Cost and error of one method on one trajectory."""
    method.reset()
    for hip in traj.hips[:200]:  # warm caches and code paths, then start over
        method.step(hip)
    method.reset()
    steps, costs = [], []
    clock = time.perf_counter_ns
    gc.collect()
    gc.disable()
    try:
        for hip in traj.hips:
            t0 = clock()
            s = method.step(hip)
            costs.append((clock() - t0) / 1000.0)
            steps.append(s)
    finally:
        gc.enable()
    errors, angles, wrong = [], [], 0
    for hip, truth, s in zip(traj.hips, traj.truths, steps):
        if (truth is not None) != s.contact:
            wrong += 1
        if truth is None and not s.contact:
            continue
        ref = truth if truth is not None else hip
        errors.append(1000.0 * sqrt(sum((s.proxy[k] - ref[k]) ** 2 for k in range(3))))
        if truth is not None and s.contact:
            want = [truth[k] - hip[k] for k in range(3)]
            depth = sqrt(sum(w * w for w in want))
            got = sqrt(sum(f * f for f in s.force))
            if 1000.0 * depth >= DEEP_MM and got > 0.0:
                c = sum(want[k] * s.force[k] for k in range(3)) / (depth * got)
                angles.append(degrees(acos(max(-1.0, min(1.0, c)))))
    return {"label": method.label, "family": method.family, "detail": method.detail,
            "cost_p50_us": round(_pct(costs, 50), 2), "cost_p99_us": round(_pct(costs, 99), 2),
            "err_p50_mm": _pct(errors, 50), "err_p99_mm": _pct(errors, 99),
            "err_max_mm": max(errors, default=0.0), "force_dir_p99_deg": round(_pct(angles, 99), 4),
            "force_dir_max_deg": round(max(angles, default=0.0), 4),
            "contact_mismatch": wrong / len(traj.hips), "ticks": len(traj.hips)}


def contact_query_cost(bodies, radius: float, traj: Trajectory) -> dict:
    """The compiled contact query alone, per tick: ``GodCore.step`` (the C step and the
    ProxyStep it returns), without the Python wrapper of GodObject and of the bench's method."""
    from server.core.haptics.compiled import chaptics

    scene = tuple(bodies)
    costs = []
    clock = time.perf_counter_ns
    for _ in range(2):  # the first pass warms caches and code paths
        core = chaptics.GodCore(radius)
        costs = []
        gc.collect()
        gc.disable()
        try:
            for hip in traj.hips:
                t0 = clock()
                core.step(scene, hip)
                costs.append((clock() - t0) / 1000.0)
        finally:
            gc.enable()
    return {"p50_us": round(_pct(costs, 50), 3), "p99_us": round(_pct(costs, 99), 3),
            "p999_us": round(_pct(costs, 99.9), 3), "ticks": len(costs)}


def pareto(points: list[dict]) -> list[str]:
    """Labels not dominated in (cost p50, error p99): nothing is both cheaper and more accurate."""
    front = []
    for p in points:
        if not any((q["cost_p50_us"] <= p["cost_p50_us"] and q["err_p99_mm"] <= p["err_p99_mm"])
                   and (q["cost_p50_us"] < p["cost_p50_us"] or q["err_p99_mm"] < p["err_p99_mm"])
                   for q in points):
            front.append(p["label"])
    return front


def choose(points: list[dict]) -> str | None:
    """The chart's choice (module docstring); None if no method fits the budget."""
    fit = [p for p in points if p["cost_p50_us"] <= BUDGET_US]
    if not fit:
        return None
    best = min(p["err_p99_mm"] for p in fit)
    tied = [p for p in fit if p["err_p99_mm"] <= best + TIE_MM]
    return min(tied, key=lambda p: (p["family"] == "penalty", p["cost_p50_us"]))["label"]


def run_accuracy_bench(out: Path, quick: bool = False) -> dict:
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} exists and is not a directory")
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    scenes = {}
    for scene in QUICK_SCENES if quick else SCENES:
        bodies, radius = scene_bodies(scene)
        traj = scene_trajectory(scene, radius, QUICK_SPEED if quick else 1.0)
        t0 = time.perf_counter()
        methods = build_methods(bodies, radius, quick=quick)
        if COMPILED:  # the analytic method is the compiled core: show the reference beside it
            methods.insert(1, reference_method(bodies, radius))
        build_s = time.perf_counter() - t0
        points = [run_method(m, traj) for m in methods]
        choice = choose(points)
        scenes[scene] = {
            "trajectory": {"ticks": len(traj.hips), "contact_ticks": sum(t is not None for t in traj.truths),
                           "segments": [{"what": w, "ticks": n} for w, n in traj.segments]},
            "proxy_radius": radius, "build_s": round(build_s, 2), "methods": points,
            "contact_query": contact_query_cost(bodies, radius, traj) if COMPILED else None,
            "pareto": pareto(points), "choice": choice, "server": SERVER_METHOD,
            "server_follows_chart": choice == SERVER_METHOD}
    overall = _overall(scenes)
    result = {"bench": "accuracy", "quick": quick, "compiled_core": COMPILED, "machine": machine_info(), "tick_hz": 1000,
              "budget_us": BUDGET_US, "tie_mm": TIE_MM, "server_method": SERVER_METHOD,
              "scenes": scenes, "overall": overall, "wall_s": round(time.perf_counter() - started, 1)}
    (out / "accuracy.json").write_text(json.dumps(result, indent=1))
    paths = chart(result, out)
    summary: dict = {"wall_s": result["wall_s"], "scenes": len(scenes),
                     "methods": len(overall["methods"])}
    for scene, s in scenes.items():
        analytic = next(p for p in s["methods"] if p["label"] == SERVER_METHOD)
        summary[f"{scene} choice"] = s["choice"]
        summary[f"{scene} analytic cost p50/p99 us"] = f"{analytic['cost_p50_us']} / {analytic['cost_p99_us']}"
        summary[f"{scene} analytic err p99 mm"] = f"{analytic['err_p99_mm']:.3g}"
        if s["contact_query"]:
            q = s["contact_query"]
            summary[f"{scene} compiled contact query p50/p99 us"] = f"{q['p50_us']} / {q['p99_us']}"
    summary["server follows chart"] = all(s["server_follows_chart"] for s in scenes.values())
    summary["json"] = str(out / "accuracy.json")
    summary["chart"] = str(paths["png"])
    return summary


def _overall(scenes: dict) -> dict:
    """One point per method over all scenes: median cost, worst error."""
    labels = [p["label"] for p in next(iter(scenes.values()))["methods"]]
    points = []
    for label in labels:
        rows = [next(p for p in s["methods"] if p["label"] == label) for s in scenes.values()]
        points.append({"label": label, "family": rows[0]["family"],
                       "cost_p50_us": round(float(np.median([r["cost_p50_us"] for r in rows])), 2),
                       "cost_p99_us": round(max(r["cost_p99_us"] for r in rows), 2),
                       "err_p99_mm": max(r["err_p99_mm"] for r in rows),
                       "force_dir_p99_deg": max(r["force_dir_p99_deg"] for r in rows)})
    return {"methods": points, "pareto": pareto(points), "choice": choose(points)}


FAMILY_STYLE = {"analytic": ("#2ca02c", "*", 14), "mesh": ("#1f77b4", "o", 7), "sdf": ("#ff7f0e", "s", 7),
                "penalty": ("#d62728", "X", 9)}


def chart(result: dict, out: Path) -> dict[str, Path]:
    panels = [(name, s["methods"], s["pareto"], s["choice"]) for name, s in result["scenes"].items()]
    o = result["overall"]
    panels.append(("all scenes (median cost, worst error)", o["methods"], o["pareto"], o["choice"]))
    cols = 3
    rows = -(-len(panels) // cols)
    fig = Figure(figsize=(15.0, 4.6 * rows), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    for ax, (title, points, front, choice) in zip(axes, panels):
        for p in points:
            colour, marker, size = FAMILY_STYLE[p["family"]]
            y = max(p["err_p99_mm"], FLOOR_MM)
            ax.plot([p["cost_p50_us"], p["cost_p99_us"]], [y, y], color=colour, alpha=0.35, lw=2)
            hollow = {"mfc": "none"} if p["label"] == REFERENCE_LABEL else {}  # same numbers, Python's cost
            ax.plot(p["cost_p50_us"], y, marker=marker, color=colour, ms=size, ls="none", **hollow)
            ax.annotate(p["label"], (p["cost_p50_us"], y), textcoords="offset points", xytext=(5, 4), fontsize=7)
            if p["label"] == choice:
                ax.plot(p["cost_p50_us"], y, marker="o", ms=size + 10, mfc="none", mec="black", mew=1.5)
        fr = sorted((p for p in points if p["label"] in front), key=lambda p: p["cost_p50_us"])
        ax.step([p["cost_p50_us"] for p in fr], [max(p["err_p99_mm"], FLOOR_MM) for p in fr], where="post",
                color="black", ls="--", lw=1, label="Pareto front")
        ax.axvline(BUDGET_US, color="grey", ls=":", lw=1, label=f"budget {BUDGET_US:g} µs (median)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        top = max(max(p["err_p99_mm"] for p in points) * 3, 1.0)  # room for labels, even when all agree
        ax.set_ylim(FLOOR_MM / 2, top)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("cost per tick, µs (marker p50, bar to p99)")
        ax.set_ylabel("proxy position error p99, mm")
        ax.grid(True, which="both", alpha=0.2)
    for ax in axes[len(panels):]:
        ax.set_visible(False)
    handles = [axes[0].plot([], [], marker=m, color=c, ms=s, ls="none", label=f)[0]
               for f, (c, m, s) in FAMILY_STYLE.items()]
    handles += [axes[0].plot([], [], color="black", ls="--", label="Pareto front")[0],
                axes[0].plot([], [], marker="o", mfc="none", mec="black", ms=14, ls="none",
                             label="the chart's choice")[0]]
    fig.legend(handles=handles, loc="outside lower center", ncols=len(handles), fontsize=9)
    fig.suptitle(f"Contact methods: cost against error on fixed trajectories over the thesis scenes "
                 f"({'quick' if result['quick'] else 'full'}; errors under {FLOOR_MM:g} mm drawn at {FLOOR_MM:g})")
    return save(fig, out, "accuracy")
