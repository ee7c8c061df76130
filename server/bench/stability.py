"""`viestac bench stability`: three sweeps that find where each contact method, the force
coupling and the contact gate fail. Every number comes from running the real code (the
god-object, the contact gate, the methods of contact_methods.py); nothing is tabulated.

1. Pop-through / tunnelling map, HIP speed x plate thickness, for every method
   ``build_methods([plate], radius=0.0)`` returns. The HIP is driven straight down through a
   0.2 x 0.2 m plate, one sample per 1 kHz tick, from more than one step above its top face to
   more than one step below its bottom face. Correct: from the first tick with the HIP below the
   top face to the end of the pass the force pushes up (f_z > 0), because the proxy stays on top.
   A run fails at the first tick below the top face with f_z <= 0: "pop-through" (f_z < 0, pushed
   out of the far side), "tunnelled" (no contact seen at all: the method never saw the plate) or
   "lost" (contact was seen, then dropped while the HIP is still below the top face). A point
   proxy is used on purpose: the scenes' 0.06 sphere proxy dilates every object by 0.12 in
   thickness and hides thin-object failures, so radius 0 is the worst case. A pass stops at its
   first failure (the outcome is decided), which bounds the cost of slow methods.
2. Stiffness x servo rate on a modelled 1-DoF force device (force_device.py), coupled to the real
   god-object on a Plane wall; Colgate & Schenkel's passivity bound K = 2b/T is drawn for
   comparison and the boundary is refined per rate by bisection.
3. Tracker noise x hysteresis band -> contact chatter of a vibration-only device: the contact-angle
   scene, the HIP's mean exactly on the dilated dome top (in contact half of the time), isotropic
   Gaussian noise sampled at 120 Hz and held over the 1 kHz ticks, the real god-object and the
   real ContactGate. The god-object does not depend on the gate (simulation.py only feeds the
   gate its output), so one god-object pass per sigma serves every gate setting.

Cost is dominated by sweep 1 for slow methods (mesh/grid methods may take ~0.1-1 ms per tick):
ticks per pass ~ thickness/step + 3, at most a few thousand for 0.1 m/s through 0.1 m.
"""

from __future__ import annotations

import json
import re
import time
from collections import Counter
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from scenarios.contact_angle import DOME_ID
from scenarios.registry import SCENARIOS
from server.analysis.figures import save
from server.bench import stability_charts
from server.bench.contact_methods import ContactMethod, MethodStep, build_methods
from server.bench.machine import machine_info
from server.bench.force_device import (START_HEIGHT_M, START_VELOCITY_M_S, ForceDevice, refine_boundary,
                                      wall_cell)
from server.config import Settings
from server.core.haptics.contact_gate import ContactGate
from server.core.haptics.god_object import GodObject
from server.core.haptics.primitives import Body, Box, Pose

SCENE_ID = "contact-angle-v1"
PLATE_SIDE = 0.2  # metres; the plate's extent in x and y
SERVER_METHOD = "analytic"  # the family of the server's own method
TRACKER_HZ = 120  # Leap Motion frame rate (docs/reference.md "Stability")
LEAP_SIGMA_M = 0.0005  # Leap Motion static jitter sigma (Guna et al. 2014: < 0.5 mm)
CHATTER_STABLE_PER_S = 0.5  # at most one spurious off/on pair every 4 s
NOISE_SEED = 20240601
# Lateral (x, y) offsets from the plate centre, one per run: with the start phases below they
# put the samples at different places relative to mesh triangles, grid cells and the faces.
RUN_OFFSETS = ((0.0, 0.0), (0.0123, 0.0071), (-0.0217, 0.0169), (0.0311, -0.0257), (-0.0058, -0.0342))
KIND_POP, KIND_TUNNEL, KIND_DELAYED, KIND_LOST = "pop-through", "tunnelled", "delayed", "lost"
KIND_LETTERS = {KIND_POP: "P", KIND_TUNNEL: "T", KIND_DELAYED: "D", KIND_LOST: "L"}  # chart labels
# A passing cell whose proxy sat deeper than this fraction of the plate below its top face passed
# the force-sign test on the wrong surface (a grid that kept only a sheet at the far face).
SANK_FRACTION = 0.5


@dataclass(frozen=True)
class Plan:
    """The grids of one run of the bench (FULL or QUICK)."""

    speeds_m_s: tuple[float, ...]
    thicknesses_m: tuple[float, ...]
    runs: int
    stiffnesses_n_per_m: tuple[float, ...]
    rates_hz: tuple[float, ...]
    wall_duration_s: float
    wall_window_s: float
    refine_iterations: int
    sigmas_m: tuple[float, ...]
    bands_m: tuple[float, ...]
    chatter_duration_s: float


FULL = Plan(speeds_m_s=(0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0),
            thicknesses_m=(0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1), runs=5,
            stiffnesses_n_per_m=tuple(round(100.0 * 10 ** (i / 6), 1) for i in range(15)),
            rates_hz=(250.0, 500.0, 1000.0, 2000.0, 4000.0), wall_duration_s=3.0, wall_window_s=0.5,
            refine_iterations=8, sigmas_m=(0.0, 0.0001, 0.00025, 0.0005, 0.001, 0.002),
            bands_m=(0.0, 0.0005, 0.001, 0.002, 0.004, 0.008), chatter_duration_s=10.0)
QUICK = Plan(speeds_m_s=(0.2, 1.0, 5.0, 20.0), thicknesses_m=(0.0005, 0.002, 0.01, 0.1), runs=3,
             stiffnesses_n_per_m=tuple(round(100.0 * 10 ** (i / 3), 1) for i in range(8)),
             rates_hz=(250.0, 1000.0, 4000.0), wall_duration_s=2.0, wall_window_s=0.5, refine_iterations=4,
             sigmas_m=(0.0, 0.0005, 0.001, 0.002), bands_m=(0.0, 0.001, 0.002, 0.004, 0.008),
             chatter_duration_s=3.0)


@dataclass(frozen=True)
class Defaults:
    """The server's defaults the sweeps check (read from the code, not restated)."""

    tick_hz: int
    stiffness_n_per_m: float
    gate_band_m: float
    gate_dwell_s: float
    scene_proxy_radius_m: float


def server_defaults() -> Defaults:
    scene = SCENARIOS[SCENE_ID].factory().build_scene()
    dome = next(b for b in scene.bodies() if b.id == DOME_ID)
    return Defaults(Settings.tick_hz, dome.stiffness_n_per_m, Settings.gate_band, Settings.gate_dwell_s,
                    scene.proxy_radius)


# -- sweep 1: pop-through / tunnelling ---------------------------------------------------------

def plate(thickness: float, stiffness: float) -> Body:
    """A PLATE_SIDE square plate of ``thickness``, top face at z = 0."""
    return Body("plate", Box((PLATE_SIDE, PLATE_SIDE, thickness)), Pose((0.0, 0.0, -0.5 * thickness)),
                stiffness_n_per_m=stiffness)


def pass_heights(top: float, bottom: float, step: float, phase: float) -> list[float]:
    """HIP heights of one straight-down pass: the first (1 + phase) steps above the top face
    (phase in [0, 1) shifts where samples land), the last more than one step below the bottom."""
    if not (step > 0.0 and 0.0 <= phase < 1.0 and bottom < top):
        raise ValueError(f"bad pass: top {top}, bottom {bottom}, step {step}, phase {phase}")
    z0 = top + step * (1.0 + phase)
    n = int((z0 - (bottom - step)) / step) + 1  # z0 - (n - 1) step < bottom - step
    while z0 - (n - 1) * step >= bottom - step:  # guard against rounding in the division
        n += 1
    return [z0 - k * step for k in range(n)]


def first_failure(ticks: Iterable[tuple[float, MethodStep]], top: float, bottom: float) -> str | None:
    """The failure kind of a pass through a plate spanning [bottom, top], or None if the force
    pushed up (f_z > 0) at every tick with the HIP below the top face. Stops consuming ``ticks``
    as soon as the kind is decided:
    pop-through: f_z < 0 (pushed out of the far side);
    lost: pushed up, then a tick without an upward push;
    tunnelled: no upward push until the HIP was through the whole plate (z <= bottom);
    delayed: the first upward push came only after the HIP had sunk below the top face (the
    method's surface lies inside the plate)."""
    pushed = sank = False
    for z, step in ticks:
        if z >= top:
            continue
        fz = step.force[2]
        if fz < 0.0:
            return KIND_POP
        if fz > 0.0:
            if sank:  # the first push, after ticks below the top without one
                return KIND_TUNNEL if z <= bottom else KIND_DELAYED
            pushed = True
        elif pushed:
            return KIND_LOST
        elif z <= bottom:
            return KIND_TUNNEL
        else:
            sank = True
    return None


def run_pass(method: ContactMethod, x: float, y: float, heights: Sequence[float], top: float,
             bottom: float) -> tuple[str | None, int, float]:
    """(failure kind or None, ticks actually stepped, deepest proxy below the top face while
    the HIP was below it) of one pass of a freshly reset method. The depth shows a method that
    passes the sign test with its proxy on the wrong surface (a grid's plate collapsed to a sheet)."""
    method.reset()
    ticks, depth = 0, 0.0

    def stream():
        nonlocal ticks, depth
        for z in heights:
            ticks += 1
            step = method.step((x, y, z))
            if z < top:
                depth = max(depth, top - step.proxy[2])
            yield z, step

    return first_failure(stream(), top, bottom), ticks, depth


def _key(method: ContactMethod) -> tuple[str, str]:
    return method.family, method.label


def popthrough_cell(method: ContactMethod, speed: float, thickness: float, runs: Sequence, tick_hz: int) -> dict:
    """One method x speed x thickness cell: a pass per (lateral offset, start phase) run."""
    step = speed / tick_hz
    kinds: Counter = Counter()
    ticks, depth = 0, 0.0
    for (x, y), phase in runs:
        kind, n, d = run_pass(method, x, y, pass_heights(0.0, -thickness, step, phase), 0.0, -thickness)
        ticks, depth = ticks + n, max(depth, d)
        if kind is not None:
            kinds[kind] += 1
    failures = sum(kinds.values())
    return {"family": method.family, "label": method.label, "speed_m_s": speed, "thickness_m": thickness,
            "runs": len(runs), "failures": failures, "fraction": failures / len(runs),
            "kinds": dict(sorted(kinds.items())), "kind": kinds.most_common(1)[0][0] if kinds else None,
            "proxy_depth_max_m": depth, "proxy_sank": not failures and depth > SANK_FRACTION * thickness,
            "ticks": ticks}


def popthrough_sweep(plan: Plan, defaults: Defaults, quick: bool) -> dict:
    """Every method x speed x thickness cell, ``plan.runs`` passes each."""
    runs = [(RUN_OFFSETS[i % len(RUN_OFFSETS)], (i + 0.5) / plan.runs) for i in range(plan.runs)]
    cells: list[dict] = []
    methods: dict[tuple[str, str], dict] = {}
    build_s = 0.0  # building meshes and grids is not part of any method's per-tick cost
    for thickness in plan.thicknesses_m:
        t0 = time.perf_counter()
        built = build_methods([plate(thickness, defaults.stiffness_n_per_m)], radius=0.0, quick=quick)
        build_s += time.perf_counter() - t0
        for method in built:
            info = methods.setdefault(_key(method), {"family": method.family, "label": method.label,
                                                     "detail": method.detail, "ticks": 0, "wall_s": 0.0})
            t0 = time.perf_counter()
            for speed in plan.speeds_m_s:
                cells.append(popthrough_cell(method, speed, thickness, runs, defaults.tick_hz))
                info["ticks"] += cells[-1]["ticks"]
            info["wall_s"] += time.perf_counter() - t0
    method_list = [dict(m, **_failure_summary([c for c in cells if (c["family"], c["label"]) == k]))
                   for k, m in methods.items()]
    r = defaults.scene_proxy_radius_m
    return {"parameters": {"speeds_m_s": list(plan.speeds_m_s), "thicknesses_m": list(plan.thicknesses_m),
                           "runs_per_cell": len(runs), "run_offsets_m": [list(o) for o, _ in runs],
                           "run_start_phases": [p for _, p in runs], "plate_side_m": PLATE_SIDE,
                           "plate_stiffness_n_per_m": defaults.stiffness_n_per_m, "tick_hz": defaults.tick_hz,
                           "proxy_radius_m": 0.0,
                           "worst_case_note": f"point proxy (radius 0): the scenes' {r:g} sphere proxy dilates "
                                              f"every object by {2 * r:g} in thickness and would hide thin-object "
                                              "failures, so radius 0 is the worst case",
                           "failure": "a tick with the HIP below the top face and force z <= 0",
                           "kinds": {KIND_POP: "force z < 0: pushed out of the far side",
                                     KIND_TUNNEL: "no upward push until the HIP was through the whole plate",
                                     KIND_DELAYED: "first upward push only after the HIP sank below the top "
                                                   "face (the method's surface lies inside the plate)",
                                     KIND_LOST: "pushed up, then no upward push with the HIP below the top"},
                           "kind_letters": KIND_LETTERS, "sank_fraction": SANK_FRACTION,
                           "proxy_sank": "a passing cell whose proxy sat more than sank_fraction of the "
                                         "thickness below the top face: right sign, wrong surface"},
            "methods": method_list, "cells": cells, "build_methods_wall_s": build_s}


def _failure_summary(cells: list[dict]) -> dict:
    """Where a method fails: counts, and its first failing cell walking from the easy corner
    (slowest speed, and at that speed the thickest plate)."""
    failing = [c for c in cells if c["failures"]]
    kinds: Counter = Counter()
    for c in failing:
        kinds.update(c["kinds"])
    first = min(failing, key=lambda c: (c["speed_m_s"], -c["thickness_m"]), default=None)
    by_speed = {}
    for c in failing:
        by_speed[c["speed_m_s"]] = max(by_speed.get(c["speed_m_s"], 0.0), c["thickness_m"])
    return {"cells": len(cells), "failing_cells": len(failing), "sank_cells": sum(c["proxy_sank"] for c in cells),
            "runs": sum(c["runs"] for c in cells), "failing_runs": sum(c["failures"] for c in cells),
            "failure_kinds": dict(sorted(kinds.items())),
            "first_failure": None if first is None else {k: first[k] for k in ("speed_m_s", "thickness_m", "kind")},
            "thickest_failing_by_speed": [{"speed_m_s": s, "thickness_m": t} for s, t in sorted(by_speed.items())]}


# -- sweep 2: stiffness x servo rate on a modelled force device -------------------------------

def stiffness_sweep(plan: Plan, device: ForceDevice, defaults: Defaults, push_n: float = 1.0) -> dict:
    opts = {"push_n": push_n, "duration_s": plan.wall_duration_s, "window_s": plan.wall_window_s}
    cells = []
    boundaries = []
    for rate in plan.rates_hz:
        row = [(k, wall_cell(device, k, rate, **opts)) for k in plan.stiffnesses_n_per_m]
        cells += [{"rate_hz": rate, "stiffness_n_per_m": k, **o.to_dict()} for k, o in row]
        boundaries.append(_rate_boundary(device, rate, row, plan.refine_iterations, opts))
    default = wall_cell(device, defaults.stiffness_n_per_m, defaults.tick_hz, **opts)
    bound = device.passivity_bound(defaults.tick_hz)
    return {"parameters": {"mass_kg": device.mass_kg, "damping_n_s_per_m": device.damping_n_s_per_m,
                           "push_n": push_n, "start_height_m": START_HEIGHT_M,
                           "start_velocity_m_s": START_VELOCITY_M_S,
                           "duration_s": plan.wall_duration_s, "window_s": plan.wall_window_s,
                           "stiffnesses_n_per_m": list(plan.stiffnesses_n_per_m), "rates_hz": list(plan.rates_hz),
                           "refine_iterations": plan.refine_iterations,
                           "assumptions": "1-DoF impedance device: mass and physical damping are assumed values "
                                          "for a desktop device, the user pushes with a constant force; the "
                                          "servo holds the god-object force between samples (zero-order hold) "
                                          "and the mass-damper is integrated in closed form between samples",
                           "oscillating": "contact lost (bounce) in the last two windows, or the late "
                                          "peak-to-peak >= the early one while above 1 % of F/K"},
            "cells": cells, "boundary_by_rate": boundaries,
            "default": {"stiffness_n_per_m": defaults.stiffness_n_per_m, "rate_hz": defaults.tick_hz,
                        "passivity_bound_n_per_m": bound, "margin": bound / defaults.stiffness_n_per_m,
                        **default.to_dict()}}


def _rate_boundary(device: ForceDevice, rate: float, row: list, iterations: int, opts: dict) -> dict:
    """The largest stable stiffness at one rate: on the grid (below the first oscillating one),
    then refined by bisection toward that oscillating neighbour."""
    first_osc = next((i for i, (_, o) in enumerate(row) if o.oscillating), len(row))
    grid_stable = row[first_osc - 1][0] if first_osc > 0 else None
    refined = oscillating = None
    if 0 < first_osc < len(row):  # a stable and an oscillating neighbour to bisect between
        refined, oscillating = refine_boundary(device, rate, grid_stable, row[first_osc][0],
                                               iterations=iterations, **opts)
    bound = device.passivity_bound(rate)
    return {"rate_hz": rate, "passivity_bound_n_per_m": bound, "largest_stable_grid_n_per_m": grid_stable,
            "largest_stable_n_per_m": refined, "smallest_oscillating_n_per_m": oscillating,
            "ratio_to_bound": None if refined is None else refined / bound}


# -- sweep 3: tracker noise x hysteresis band -> chatter ---------------------------------------

def resting_point(bodies: Sequence[Body], radius: float, x: float = 0.0, y: float = 0.0) -> tuple:
    """Where a vertical line through (x, y) first meets the bodies dilated by ``radius``: the
    hand's mean position when it rests exactly on the surface."""
    top, bottom = (x, y, 100.0), (x, y, -100.0)
    hits = [t for b in bodies if (t := b.cast(top, bottom, radius)) is not None]
    if not hits:
        raise ValueError(f"nothing below ({x}, {y}) to rest on")
    return (x, y, top[2] + min(hits) * (bottom[2] - top[2]))


def contact_signal(bodies: Sequence[Body], radius: float, mean: tuple, noise: np.ndarray, tick_hz: int,
                   tracker_hz: int, n_ticks: int) -> list[tuple[bool, float]]:
    """(touching, separation) of the real god-object at every tick, for tracker samples
    mean + noise[k] arriving at tracker_hz and held over the ticks (zero-order hold)."""
    god = GodObject(radius)
    out = []
    for i in range(n_ticks):
        d = noise[(i * tracker_hz) // tick_hz]
        step = god.step(bodies, (mean[0] + d[0], mean[1] + d[1], mean[2] + d[2]))
        out.append((bool(step.contacts), step.separation))
    return out


def chatter_rate(signal: Sequence[tuple[bool, float]], gate: ContactGate, tick_hz: int) -> float:
    """Gated contact transitions per second after the first switch-on (that one is the contact
    itself; every later change is chatter while the hand rests on the surface)."""
    gate.reset()
    state, changes, started = False, 0, False
    for i, (touching, separation) in enumerate(signal):
        on = gate.update(i / tick_hz, touching, separation)
        if on != state:
            changes += started
            started = True
            state = on
    return changes / (len(signal) / tick_hz)


def chatter_sweep(plan: Plan, defaults: Defaults) -> dict:
    scene = SCENARIOS[SCENE_ID].factory().build_scene()
    bodies, radius = list(scene.bodies()), scene.proxy_radius
    mean = resting_point(bodies, radius)
    n_ticks = round(plan.chatter_duration_s * defaults.tick_hz)
    unit_noise = np.random.default_rng(NOISE_SEED).standard_normal(
        ((n_ticks * TRACKER_HZ) // defaults.tick_hz + 1, 3))
    dwell = defaults.gate_dwell_s
    cells = []
    for sigma in plan.sigmas_m:
        signal = contact_signal(bodies, radius, mean, sigma * unit_noise, defaults.tick_hz, TRACKER_HZ, n_ticks)
        cells.append({"sigma_m": sigma, "gate": "raw", "band_m": 0.0, "dwell_s": 0.0,
                      "chatter_per_s": chatter_rate(signal, ContactGate(0.0, 0.0, 0.0), defaults.tick_hz)})
        for band in plan.bands_m:
            rate = chatter_rate(signal, ContactGate(band, dwell, dwell), defaults.tick_hz)
            cells.append({"sigma_m": sigma, "gate": "hysteresis", "band_m": band, "dwell_s": dwell,
                          "chatter_per_s": rate})
    for c in cells:
        c["stable"] = c["chatter_per_s"] <= CHATTER_STABLE_PER_S
    stable_band = [{"sigma_m": s, "smallest_stable_band_m": min(
        (c["band_m"] for c in cells if c["sigma_m"] == s and c["gate"] == "hysteresis" and c["stable"]),
        default=None)} for s in plan.sigmas_m]
    return {"parameters": {"scene": SCENE_ID, "proxy_radius_m": radius, "mean_hip_m": list(mean),
                           "tracker_hz": TRACKER_HZ, "tick_hz": defaults.tick_hz, "hold": "zero-order",
                           "noise": "isotropic Gaussian, sigma per axis", "seed": NOISE_SEED,
                           "duration_s": plan.chatter_duration_s, "sigmas_m": list(plan.sigmas_m),
                           "bands_m": list(plan.bands_m), "dwell_s": dwell, "default_band_m": defaults.gate_band_m,
                           "leap_sigma_m": LEAP_SIGMA_M,
                           "stable_threshold_per_s": CHATTER_STABLE_PER_S,
                           "chatter": "gated transitions per second after the first switch-on; 'raw' is the "
                                      "gate with band 0 and dwell 0"},
            "cells": cells, "stable_band_by_sigma": stable_band}


def _chatter_at(chatter: dict, sigma: float, band: float | None) -> dict:
    """The cell at sigma with the given band (None: the raw gate)."""
    for c in chatter["cells"]:
        if c["sigma_m"] == sigma and (c["gate"] == "raw" if band is None else
                                      c["gate"] == "hysteresis" and c["band_m"] == band):
            return c
    raise KeyError(f"no chatter cell at sigma {sigma} band {band}: the plan must include the defaults")


# -- the bench --------------------------------------------------------------------------------

def _output_dir(out: Path) -> Path:
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} exists and is not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"cannot create the output directory {out}: {exc}") from None
    return out


def _timed(fn, *args) -> tuple[dict, float]:
    t0 = time.perf_counter()
    result = fn(*args)
    return result, time.perf_counter() - t0


def _defaults_verdict(pop: dict, stiff: dict, chatter: dict, defaults: Defaults) -> dict:
    server = [m for m in pop["methods"] if m["family"] == SERVER_METHOD]
    leap = _chatter_at(chatter, LEAP_SIGMA_M, defaults.gate_band_m)
    wall = stiff["default"]
    return {
        "contact_method": {"family": SERVER_METHOD, "failing_runs": sum(m["failing_runs"] for m in server),
                           "runs": sum(m["runs"] for m in server),
                           "stable": bool(server) and all(m["failing_runs"] == 0 for m in server)},
        "stiffness": {"stiffness_n_per_m": wall["stiffness_n_per_m"], "rate_hz": wall["rate_hz"],
                      "passivity_bound_n_per_m": wall["passivity_bound_n_per_m"], "margin": wall["margin"],
                      "relative_p2p": wall["relative_p2p"], "stable": not wall["oscillating"]},
        "gate": {"band_m": defaults.gate_band_m, "dwell_s": defaults.gate_dwell_s, "sigma_m": LEAP_SIGMA_M,
                 "chatter_per_s": leap["chatter_per_s"], "stable": leap["stable"]},
    }


def run_stability_bench(out: Path, quick: bool = False) -> dict:
    """Run the three sweeps, write DIR/stability.json and the charts; returns the summary."""
    out = _output_dir(out)
    plan = QUICK if quick else FULL
    defaults = server_defaults()
    device = ForceDevice()
    pop, pop_s = _timed(popthrough_sweep, plan, defaults, quick)
    stiff, stiff_s = _timed(stiffness_sweep, plan, device, defaults)
    chatter, chatter_s = _timed(chatter_sweep, plan, defaults)
    for section, wall_s in ((pop, pop_s), (stiff, stiff_s), (chatter, chatter_s)):
        section["wall_s"] = wall_s
    verdict = _defaults_verdict(pop, stiff, chatter, defaults)
    charts = {name: save(figure(section), out, name) for name, figure, section in (
        ("popthrough", stability_charts.popthrough, pop), ("stiffness", stability_charts.stiffness, stiff),
        ("chatter", stability_charts.chatter, chatter))}
    report = {"schema": "viestac-stability/1", "quick": quick, "machine": machine_info(),
              "server_defaults": asdict(defaults), "popthrough": pop, "stiffness": stiff, "chatter": chatter,
              "defaults": verdict}
    json_path = out / "stability.json"
    summary = _summary(report, json_path, charts)
    report["summary"] = summary
    json_path.write_text(json.dumps(report, indent=1) + "\n")
    return summary


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "_", text.lower()).strip("_")


def _mm(metres: float | None) -> str:
    return "none" if metres is None else f"{metres * 1000:g} mm"


def _method_line(m: dict) -> str:
    sank = f"; {m['sank_cells']} passing cells with the proxy on the far side" if m["sank_cells"] else ""
    if not m["failing_cells"]:
        return f"0/{m['cells']} cells fail ({m['runs']} runs){sank}"
    kinds = ", ".join(f"{k} {n}" for k, n in m["failure_kinds"].items())
    first = m["first_failure"]
    return (f"{m['failing_cells']}/{m['cells']} cells fail ({m['failing_runs']}/{m['runs']} runs: {kinds}); first at "
            f"{first['speed_m_s']:g} m/s through {_mm(first['thickness_m'])} ({first['kind']}){sank}")


def _summary(report: dict, json_path: Path, charts: dict) -> dict:
    pop, stiff, chatter, verdict = (report[k] for k in ("popthrough", "stiffness", "chatter", "defaults"))
    tick_hz = report["server_defaults"]["tick_hz"]
    at_tick = next(b for b in stiff["boundary_by_rate"] if b["rate_hz"] == tick_hz)
    wall = stiff["default"]
    summary: dict = {
        "wall_s_popthrough": round(pop["wall_s"], 2), "wall_s_stiffness": round(stiff["wall_s"], 2),
        "wall_s_chatter": round(chatter["wall_s"], 2),
        "popthrough_analytic_failing_runs": verdict["contact_method"]["failing_runs"],
        "popthrough_failing_methods": ", ".join(f"{m['family']}:{m['label']}" for m in pop["methods"]
                                                if m["failing_cells"]) or "none",
    }
    for m in pop["methods"]:
        summary[f"popthrough_{_slug(m['family'] + ' ' + m['label'])}"] = _method_line(m)
    summary.update({
        f"stiffness_largest_stable_at_{tick_hz}hz_n_per_m": _round(at_tick["largest_stable_n_per_m"]),
        f"stiffness_passivity_bound_at_{tick_hz}hz_n_per_m": at_tick["passivity_bound_n_per_m"],
        "stiffness_largest_stable_by_rate": "; ".join(
            f"{b['rate_hz']:g} Hz: {_round(b['largest_stable_n_per_m'] or b['largest_stable_grid_n_per_m'])} "
            f"(2b/T {b['passivity_bound_n_per_m']:g})" for b in stiff["boundary_by_rate"]),
        "stiffness_default": (f"{'oscillating' if wall['oscillating'] else 'stable'}: "
                              f"{wall['stiffness_n_per_m']:g} N/m at {wall['rate_hz']:g} Hz, 2b/T = "
                              f"{wall['passivity_bound_n_per_m']:g} N/m, late ripple {wall['relative_p2p']:.2g} F/K"),
    })
    gate_band = report["server_defaults"]["gate_band_m"]
    for sigma in (LEAP_SIGMA_M, max(chatter["parameters"]["sigmas_m"])):
        key = f"{sigma * 1000:g}mm"
        for name, band in (("default", gate_band), ("raw", None)):
            summary[f"chatter_{name}_sigma_{key}_per_s"] = round(_chatter_at(chatter, sigma, band)["chatter_per_s"], 3)
    summary["chatter_stable_band_by_sigma"] = "; ".join(
        f"sigma {_mm(s['sigma_m'])}: {_mm(s['smallest_stable_band_m'])}" for s in chatter["stable_band_by_sigma"])
    summary["defaults_stable"] = all(v["stable"] for v in verdict.values())
    summary.update({f"default_{k}_stable": v["stable"] for k, v in verdict.items()})
    summary["out_json"] = str(json_path)
    summary["out_charts"] = ", ".join(str(p) for paths in charts.values() for p in paths.values())
    return summary


def _round(value: float | None) -> float | None:
    return None if value is None else round(value, 1)
