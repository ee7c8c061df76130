"""ISO 9241-411 throughput of the positioning trials, where the data allow it.

Per trial (needs the held object's recorded samples and the scenario's `pick` and `go` events):
- start S = the object's resting place, target T = the point above its hole it must be held at
  (scenarios/positioning.py: ITEMS, TARGET_CLEARANCE); u = (T − S)/|T − S|, D = |T − S|;
- end point E = the object's mean position over the hold that led to GO (load.py);
- signed deviation along the task axis dx = (E − T)·u, actual amplitude a = (E − S)·u;
- movement time MT = (GO − pick)/tick_hz − hold_s: pick to the start of that hold.
Per condition (device, cue, object), over the participants' trials (each participant does each
condition once in the thesis's design, so the spread can only be taken across participants):
We = 4.133·SD(dx), Ae = mean a, IDe = log2(Ae/We + 1), TP = IDe / mean MT (bits/s); per device and
per cue the mean TP of its conditions (ISO 9241-411's mean of means).

Caveat (in the report too): GO needs the object within the target tolerance on every axis for the
whole hold, so the end points are truncated to that box by design; We measures the hold's jitter
inside it, not a free pointing spread, and TP is comparable between devices and cues of this
task only, not with pointing throughputs in the literature.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from server.analysis.stats import Skip, num

WE_FACTOR = 4.133       # ISO 9241-411: We = 4.133·SD (the 96 % of a normal spread)
MIN_TRIALS = 3          # an SD of fewer end points says nothing


def item_geometry() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """object id → (start, target) in scene units, from the positioning scenario's layout."""
    from scenarios.positioning import ITEMS, TARGET_CLEARANCE

    return {i.id: (np.array((*i.start, i.half)), np.array((*i.hole_at, i.hole.height + TARGET_CLEARANCE + i.half)))
            for i in ITEMS}


def per_trial(frame: pd.DataFrame, endpoints: pd.DataFrame, geometry: dict) -> pd.DataFrame:
    """The task-4 trials that have an end point, with D, dx, a and MT."""
    rows = frame.merge(endpoints, on="trial_id", how="inner")
    rows = rows[(rows["hole_speed"] == 0) & rows["object"].isin(geometry) & rows["pick_tick"].notna()]
    out = []
    for r in rows.itertuples():
        start, target = geometry[r.object]
        axis = target - start
        d = float(np.linalg.norm(axis))
        u = axis / d
        end = np.array((r.end_x, r.end_y, r.end_z))
        out.append({"trial_id": r.trial_id, "participant": r.participant, "device": r.device, "cue": r.cue,
                    "object": r.object, "D": d, "dx": float((end - target) @ u), "a": float((end - start) @ u),
                    "mt": (r.go_tick - r.pick_tick) / r.tick_hz - r.hold_s})
    return pd.DataFrame(out, columns=("trial_id", "participant", "device", "cue", "object", "D", "dx", "a", "mt"))


def throughput(frame: pd.DataFrame, endpoints: pd.DataFrame, geometry: dict | None = None) -> dict:
    """stats.json's `task4.throughput`; Skip with what is missing when the data do not allow it."""
    if frame.empty:
        raise Skip("no positioning trials")
    geometry = item_geometry() if geometry is None else geometry
    trials = per_trial(frame, endpoints, geometry)
    if trials.empty:
        moving = int((frame["hole_speed"] > 0).sum())
        raise Skip("needs, per positioning trial, the recorded samples of the held object during the hold and the "
                   f"scenario's pick and go events; none of the {len(frame)} trials has them"
                   + (f" ({moving} had moving holes, whose distance is not fixed)" if moving else ""))
    conditions, short = [], 0
    for (device, cue, obj), g in trials.groupby(["device", "cue", "object"], sort=True):
        sd = float(g["dx"].std(ddof=1)) if len(g) > 1 else 0.0
        if len(g) < MIN_TRIALS or sd == 0 or (g["mt"] <= 0).any():
            short += 1
            continue
        we = WE_FACTOR * sd
        ae = float(g["a"].mean())
        ide = float(np.log2(ae / we + 1))
        mt = float(g["mt"].mean())
        conditions.append({"device": device, "cue": cue, "object": obj, "n": int(len(g)), "D": num(g["D"].iloc[0]),
                           "Ae": num(ae), "sd_dx": num(sd), "We": num(we), "IDe": num(ide), "MT": num(mt),
                           "TP": num(ide / mt)})
    if not conditions:
        raise Skip(f"no condition (device, cue, object) has {MIN_TRIALS} or more trials with an end point, a spread "
                   f"of end points and a positive movement time ({len(trials)} trials with end points)")
    table = pd.DataFrame(conditions)
    return {"method": "ISO 9241-411: We = 4.133·SD(dx), IDe = log2(Ae/We + 1), TP = IDe/MT per condition, "
                      "pooled over participants; mean of the conditions per device and per cue",
            "n_trials": int(len(trials)), "n_conditions_skipped": short, "conditions": conditions,
            "by_device": {d: num(g["TP"].mean()) for d, g in table.groupby("device", sort=True)},
            "by_cue": {f"{d}/{c}": num(g["TP"].mean()) for (d, c), g in table.groupby(["device", "cue"], sort=True)}}
