"""`viestac bench tracking`: speed against accuracy for tracking, and Leap sample → device command.

1. **Filters on noisy finger paths** (deterministic, no server). Finger paths that touch a flat
   surface (z = 0; approach, press 5 mm-equivalent in, hold, slide, lift; slow and fast moves)
   are sampled at the Leap's 110 Hz with tracker-like noise (Gaussian, σ = 0.4 mm at the Leap's
   default 0.005 scene units per mm; `NOISE_SIGMA`) and run through: raw, the 1€ filter
   (server/tracking/one_euro.py: the defaults and a sweep of f_c,min × β), and a moving average
   of N samples. For each: *jitter* (RMS of filtered − true while the finger rests), *lag* (the
   time shift that best aligns filtered with true while it moves) and *contact chatter* (contact
   transitions of the filtered z < 0 per transition of the true one: 1 is none). The chart
   (jitter against lag, with the front of the points no other beats in both) shows where the
   defaults sit; `defaults_on_front` says whether any filter beats them in both.
2. **Leap sample → device command** (`--latency-seconds`, 0 skips it): the whole server with
   `--viewers` viewers (default 64): Leap emulator (its frames stamped on CLOCK_MONOTONIC as
   sent) → tracker host (calibration, 1€) → UDP → loop → cue channel → device host → pty →
   FerroVibe emulator (the first command frame that shows the switch, stamped as read). The
   path jumps so that the *first* filtered sample crosses the surface (hover 6 mm-equivalent
   above, jump 0.3 deep; rest just inside, jump 0.3 out), so this is the pipeline's latency and
   not the filter's lag (part 1 measures that). Same end point as `viestac bench latency`'s
   `read_*` (server/bench/latency_bench.py).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from server.tracking.one_euro import DEFAULT_PARAMS, OneEuro3, OneEuroParams

RATE_HZ = 110.0
NOISE_SIGMA = 0.002        # scene units: 0.4 mm of Leap jitter at 0.005 units/mm
TRACKER_DELAY_S = 0.0      # the same for every filter; lag is measured against the true path
SWEEP_MIN_CUTOFF = (0.1, 0.3, 1.0, 3.0, 10.0)
SWEEP_BETA = (0.0, 1.0, 5.0, 20.0, 80.0)
MOVING_AVERAGE = (2, 4, 8, 16)


SEGMENT_S = 2.6


def true_path(seed: int, seconds: float = 26.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times, true positions (n × 3) and a rest label per sample (−1 moving or settling, else the
    rest's number): touches of a surface at z = 0, each: rest above (0.8 s), reach down at a slow,
    normal or fast speed, rest pressed in (0.8 s; a light touch 0.004 deep, where noise makes
    contact chatter, or a firm one 0.025 deep), slide, lift, and on to the next."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, 1.0 / RATE_HZ)
    p = np.zeros((len(t), 3))
    label = np.full(len(t), -1)
    n_seg = int(seconds // SEGMENT_S)
    for k in range(n_seg):
        seg_start = k * SEGMENT_S
        speed = rng.choice([0.3, 1.0, 3.0])  # scene units per second
        above = 0.08 + 0.04 * rng.random()
        depth = -0.004 if k % 2 == 0 else -0.025
        x0, y0 = rng.uniform(-0.2, 0.2, 2)
        reach = (above - depth) / speed
        slide = 0.3
        slide_speed = rng.choice([0.02, 0.05, speed])  # slow exploration of the surface, or a quick stroke
        for i in np.nonzero((t >= seg_start) & (t < seg_start + SEGMENT_S))[0]:
            u = t[i] - seg_start
            if u < 0.8:
                z, dx, lab = above, 0.0, (2 * k if u >= 0.4 else -1)  # the rest's second half: settled
            elif u < 0.8 + reach:
                z, dx, lab = above + (depth - above) * (u - 0.8) / reach, 0.0, -1
            elif u < 1.6 + reach:
                z, dx, lab = depth, 0.0, (2 * k + 1 if u >= 1.2 + reach else -1)
            elif u < 1.6 + reach + slide:
                z, dx, lab = depth, slide_speed * (u - 1.6 - reach), -1
            elif u < 1.6 + 2 * reach + slide:
                z, dx, lab = depth + (above - depth) * (u - 1.6 - reach - slide) / reach, slide_speed * slide, -1
            else:
                z, dx, lab = above, slide_speed * slide, -1
            p[i] = (x0 + dx, y0, z)
            label[i] = lab
    return t, p, label


def noisy(p: np.ndarray, seed: int) -> np.ndarray:
    return p + np.random.default_rng(seed + 1000).normal(0.0, NOISE_SIGMA, p.shape)


def one_euro(t, x, params: OneEuroParams) -> np.ndarray:
    f = OneEuro3(params)
    return np.array([f(row, ti) for ti, row in zip(t, x)])


def moving_average(x: np.ndarray, n: int) -> np.ndarray:
    out = np.empty_like(x)
    c = np.cumsum(np.vstack([np.zeros((1, 3)), x]), axis=0)
    for i in range(len(x)):
        lo = max(0, i + 1 - n)
        out[i] = (c[i + 1] - c[lo]) / (i + 1 - lo)
    return out


def metrics(t, truth, label, y) -> dict:
    """jitter: RMS distance of the filtered point from its own mean over each settled rest (the
    wobble a resting finger shows); lag: the shift that best aligns filtered with true while
    moving; chatter: filtered contact transitions per true one."""
    sq, count = 0.0, 0
    for lab in np.unique(label[label >= 0]):
        w = y[label == lab]
        sq += float(((w - w.mean(axis=0)) ** 2).sum())
        count += len(w)
    jitter = math.sqrt(sq / max(count, 1))
    moving = label < 0
    best, lag = math.inf, 0.0
    for shift_ms in np.arange(0.0, 150.0, 1.0):  # the true path delayed by `shift`, interpolated
        shifted = np.column_stack([np.interp(t - shift_ms / 1000, t, truth[:, a]) for a in range(3)])
        err = float(np.sqrt(((y[moving] - shifted[moving]) ** 2).sum(axis=1).mean()))
        if err < best:
            best, lag = err, shift_ms / 1000
    contact_true = truth[:, 2] < 0
    contact = y[:, 2] < 0
    true_transitions = int(np.count_nonzero(np.diff(contact_true.astype(int))))
    transitions = int(np.count_nonzero(np.diff(contact.astype(int))))
    return {"jitter": round(jitter, 6), "lag_ms": round(lag * 1000, 2), "moving_rms": round(best, 6),
            "chatter": round(transitions / max(true_transitions, 1), 3)}


def _front(points: list[dict]) -> list[str]:
    """The names of the points no other point beats in both jitter and lag."""
    names = []
    for p in points:
        if not any(q["jitter"] <= p["jitter"] and q["lag_ms"] <= p["lag_ms"]
                   and (q["jitter"] < p["jitter"] or q["lag_ms"] < p["lag_ms"]) for q in points):
            names.append(p["name"])
    return names


def filter_study(seeds=(1, 2, 3), seconds: float = 26.0) -> dict:
    runs: dict[str, list[dict]] = {}

    def add(name, kind, params, fn):
        for seed in seeds:
            t, truth, label = true_path(seed, seconds)
            runs.setdefault(name, []).append({"kind": kind, "params": params,
                                              **metrics(t, truth, label, fn(t, noisy(truth, seed)))})

    add("raw", "raw", {}, lambda t, x: x)
    add("1euro-default", "1euro-default", DEFAULT_PARAMS.to_dict(), lambda t, x: one_euro(t, x, DEFAULT_PARAMS))
    for fc in SWEEP_MIN_CUTOFF:
        for beta in SWEEP_BETA:
            params = OneEuroParams(fc, beta)
            add(f"1euro fc={fc:g} b={beta:g}", "1euro", params.to_dict(), lambda t, x, p=params: one_euro(t, x, p))
    for n in MOVING_AVERAGE:
        add(f"ma{n}", "moving-average", {"n": n}, lambda t, x, n=n: moving_average(x, n))
    points = []
    for name, rs in runs.items():
        points.append({"name": name, "kind": rs[0]["kind"], "params": rs[0]["params"],
                       **{k: round(float(np.mean([r[k] for r in rs])), 6) for k in ("jitter", "lag_ms", "chatter")}})
    front = _front(points)
    return {"rate_hz": RATE_HZ, "noise_sigma": NOISE_SIGMA, "seeds": list(seeds), "seconds_per_path": seconds,
            "filters": points, "front": front, "defaults": DEFAULT_PARAMS.to_dict(),
            "defaults_on_front": "1euro-default" in front}


def chart(result: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 5))
    colours = {"raw": "black", "1euro": "tab:blue", "1euro-default": "tab:red", "moving-average": "tab:green"}
    for p in result["filters"]:
        ax.scatter(p["lag_ms"], p["jitter"] * 1000, c=colours[p["kind"]], s=60 if p["kind"] != "1euro" else 20,
                   marker="*" if p["kind"] == "1euro-default" else "o", zorder=3 if p["kind"] != "1euro" else 2)
        ax2.scatter(p["lag_ms"], p["chatter"], c=colours[p["kind"]], s=20)
        if p["kind"] != "1euro":
            ax.annotate(p["name"], (p["lag_ms"], p["jitter"] * 1000), fontsize=7, xytext=(3, 3),
                        textcoords="offset points")
    front = sorted((p for p in result["filters"] if p["name"] in result["front"]), key=lambda p: p["lag_ms"])
    ax.plot([p["lag_ms"] for p in front], [p["jitter"] * 1000 for p in front], "k--", lw=0.8, label="front")
    ax.set_xlabel("lag while moving (ms)")
    ax.set_ylabel("jitter at rest (RMS, 10⁻³ scene units)")
    ax.set_yscale("log")
    ax.set_title("1€ (blue: sweep, red star: defaults), moving average (green), raw (black)")
    ax.legend()
    ax2.set_xlabel("lag while moving (ms)")
    ax2.set_ylabel("contact transitions per true transition (1 = no chatter)")
    ax2.set_yscale("log")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ---- part 2: Leap sample → device command through the whole server ---------------------------

BLOCK_S = 0.06


def switch_path(rate_hz: float = RATE_HZ):
    """One cycle of the latency path on the contact-angle dome's top (angle 0): rest 6 mm-eq above
    (off), jump 0.3 deep (on at the first sample), come back to just inside, jump 0.3 out (off at
    the first sample). Returns (times, rows, {frame index: state it switches to})."""
    from scenarios.contact_angle import point_at_angle

    surface = 0.6 + 0.06
    n = int(BLOCK_S * rate_hz)
    levels = [surface + 0.03, surface - 0.3, surface - 0.03, surface + 0.3]
    rows, switches = [], {}
    for b, level in enumerate(levels):
        if b in (1, 3):
            switches[len(rows)] = b == 1
        for _ in range(n):
            rows.append({"right.index.tip": point_at_angle(0.0, level)})
    return [i / rate_hz for i in range(len(rows))], rows, switches


def latency_study(seconds: float, viewers: int) -> dict:
    from server.bench.leap_rig import LeapRig
    from server.bench.loop_bench import off_loop_cpu, token_option
    from server.launcher import get_json
    from server.bench.quantiles import tail

    times, rows, switches = switch_path()
    cycle = len(rows)
    with LeapRig(times, rows, realtime=True) as rig:
        emulator = rig.emulators["ferrovibe"]
        load = subprocess.Popen([sys.executable, "-m", "server.bench.load", "--url",
                                 rig.base.replace("http://", "ws://") + "/ws", "--viewers", str(viewers),
                                 "--trackers", "0", "--warmup", "2", "--seconds", str(seconds),
                                 *token_option(rig.base), *off_loop_cpu(rig.base)],
                                stdout=subprocess.PIPE, text=True)
        time.sleep(3.0)
        start_ns = time.monotonic_ns()
        get_json(rig.base + "/api/telemetry/reset", "POST")
        time.sleep(seconds)
        end_ns = time.monotonic_ns()
        telemetry = get_json(rig.base + "/api/telemetry")
        source = rig.source()
        load.communicate(timeout=120)
        time.sleep(0.1)
        frames = rig.frames_sent()
        edges = [e for e in emulator.snapshot_edges() if e.cause == "command"]
        read_at = {arrival: read for arrival, read, _chunk in emulator.snapshot_read_at()}
    shown = sorted((read_at.get(e.t_us, e.t_us), e.magnitude > 0) for e in edges)
    reads = [s[0] for s in shown]
    import bisect

    lat, missed = [], 0
    sends = [(sent_ns // 1000, switches[(fid - 1) % cycle]) for fid, sent_ns in frames
             if (fid - 1) % cycle in switches and start_ns <= sent_ns <= end_ns]
    for i, (t_us, on) in enumerate(sends):
        limit = sends[i + 1][0] if i + 1 < len(sends) else math.inf
        k = bisect.bisect_left(reads, t_us)
        while k < len(shown) and shown[k][0] < limit and shown[k][1] != on:
            k += 1
        if k < len(shown) and shown[k][0] < limit:
            lat.append((shown[k][0] - t_us) / 1000)
        else:
            missed += 1
    lat.sort()
    return {"viewers": viewers, "seconds": seconds, "samples": len(lat), "missed": missed,
            **tail(lat, "", "_ms"),
            "period_p99_us": telemetry.get("period_p99_us"), "overruns": telemetry.get("overruns"),
            "rt": telemetry.get("rt"), "leap_source": {k: source.get(k) for k in ("status", "rate_hz", "gaps")},
            "end_point": "FerroVibe emulator's read of the first command frame showing the switch "
                         "(as latency_bench read_*), from the Leap emulator's send of the switching frame"}


def run_tracking_bench(out: Path, latency_seconds: float = 130.0, viewers: int = 64) -> dict:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    result = {"filters": filter_study()}
    chart(result["filters"], out / "tracking_filters.png")
    result["chart"] = str(out / "tracking_filters.png")
    if latency_seconds > 0:
        result["latency"] = latency_study(latency_seconds, viewers)
    (out / "tracking.json").write_text(json.dumps(result, indent=1))
    return result
