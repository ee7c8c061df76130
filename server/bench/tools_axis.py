"""The tools axis of `viestac bench objects`: the loop's cost per tick against the number of tools
(tracked fingertips, 1 to 10), on the contact-angle scene.

N fingertips (the primary `right.index.tip`, then the other fingertips of both hands) each rest
3 mm inside the dome, spread around it and sweeping up and down its side, so every tool is in
contact, its gate on and its god-object sliding. One tracker source sends every point in one
sample (a hand tracker's `points`), as the loop receives it.

Two costs per tick, both timed in-process with perf_counter_ns, the garbage collector's view of
the start-up frozen as in the loop process (no sockets, no sleeping, so the caches are warm:
the live tick in `viestac bench loop` costs more, docs/performance.md):
- **god-object**: the tools' proxy steps alone (CompiledGodObject.step per tool, the same HIPs);
- **tick**: `Loop.tick` with the sample, plus msgpack encoding of the state record when one
  is due (what the loop process does before it sends it): the whole tick minus the socket calls.
Each at two sample rates: a sample every 8th tick (a 120 Hz tracker; the HIP is held between
samples) and a sample every tick (every tick moves every tool; the cues change, so every tick
publishes a state record: the worst case).
"""

from __future__ import annotations

import gc
import math
import time

import numpy as np

from server import ipc
from server.ipc.records import TrackerSample
from server.core.points import PRIMARY_POINT
from server.core.tool import DEFAULT_PROXY_RADIUS
from server.loop.process import LoopConfig, build_core

TOOL_COUNTS = (1, 2, 3, 4, 5, 6, 7, 8, 9, 10)
QUICK_TOOL_COUNTS = (1, 2, 5, 10)
FINGERTIPS = (PRIMARY_POINT, "right.thumb.tip", "right.middle.tip", "right.ring.tip", "right.pinky.tip",
              "left.thumb.tip", "left.index.tip", "left.middle.tip", "left.ring.tip", "left.pinky.tip")
DOME = 0.6 + DEFAULT_PROXY_RADIUS - 0.003  # 3 mm inside the dilated dome (as bench loop's trackers)
TICKS = 4000
QUICK_TICKS = 1500
WARM_UP = 200


def fingertip(k: int, tick: int) -> tuple[float, float, float]:
    """Where fingertip k is at `tick`: its own meridian of the dome (the primary's on the arc
    facing the camera, where its contact angle changes as it moves; the others 36° apart),
    sweeping 10-70° from the top at 0.25 Hz."""
    azimuth = math.radians(90.0 + 36.0 * k)
    polar = math.radians(40.0 + 30.0 * math.sin(2 * math.pi * 0.25 * tick / 1000.0 + k))
    return (DOME * math.sin(polar) * math.cos(azimuth), DOME * math.sin(polar) * math.sin(azimuth),
            DOME * math.cos(polar))


def sample(n: int, tick: int, seq: int) -> TrackerSample:
    """The loop's tracker record for one sample of n fingertips (server/loop/tick.py apply)."""
    pos = fingertip(0, tick)
    points = {FINGERTIPS[k]: fingertip(k, tick) for k in range(1, n)}
    return TrackerSample("hand", seq, tick, list(pos), None, tick * 1_000_000, PRIMARY_POINT, points or None, None)


def _quantiles(costs_ns: list[int]) -> dict:
    xs = np.asarray(costs_ns, dtype=float) / 1000.0
    return {"p50_us": round(float(np.percentile(xs, 50)), 2), "p99_us": round(float(np.percentile(xs, 99)), 2)}


def time_tools(n: int, every: int, ticks: int) -> dict:
    """Cost per tick with n tools and a tracker sample every `every` ticks."""
    core = build_core(LoopConfig(scenario="contact-angle", rig=FINGERTIPS[1:n], realtime=False))
    core.outbox.clear()
    tools = core.sim.data.tools
    clock = time.perf_counter_ns
    tick_ns, god_ns, states = [], [], 0
    gc.collect()
    gc.freeze()
    try:
        for i in range(WARM_UP + ticks):
            records = [sample(n, i, i)] if i % every == 0 else ()
            t0 = clock()
            out = core.tick(records, i * 1_000_000)
            if out.state is not None:
                ipc.pack(out.state)
            t1 = clock()
            core.record_sample(1_000_000, t1 - t0, out.state is not None)
            if i >= WARM_UP:
                tick_ns.append(t1 - t0)
                states += out.state is not None
        # the god-object alone, on the same HIPs, one fresh god-object per tool
        bodies = core.sim.data.bodies
        gods = [type(tool.god)(tool.proxy_radius) for tool in tools]
        for i in range(WARM_UP + ticks):
            hips = [fingertip(k, i - i % every) for k in range(n)]
            t0 = clock()
            for god, hip in zip(gods, hips):
                god.step(bodies, hip)
            t1 = clock()
            if i >= WARM_UP:
                god_ns.append(t1 - t0)
    finally:
        gc.unfreeze()
    contact = all(view.contact for view in out.result.tools)
    return {"tick": _quantiles(tick_ns), "god_object": _quantiles(god_ns), "states_per_tick": round(states / ticks, 3),
            "all_in_contact": contact}


def run_tools_axis(quick: bool = False) -> list[dict]:
    ticks = QUICK_TICKS if quick else TICKS
    rows = []
    for n in QUICK_TOOL_COUNTS if quick else TOOL_COUNTS:
        rows.append({"tools": n, "sample_every_8": time_tools(n, 8, ticks), "sample_every_tick": time_tools(n, 1, ticks)})
    return rows
