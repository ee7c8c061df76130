"""The pure parts of `viestac bench roundtrip`: the participant's HIP paths, matching tracker
samples to the state frames that show them, and the summary. No I/O (roundtrip_bench.py runs it).

A sample is shown by a state frame whose `hip` equals the sample's position. The loop publishes
`hip` rounded to 9 decimals (server/loop/tick.py), so the paths are rounded the same way and the
comparison is exact; each position carries a tag of one micrometre per sample index (mod 1000),
so any 1000 consecutive samples are distinct and a frame names exactly one of them.
"""

from __future__ import annotations

import bisect
import math

from scenarios.contact_angle import PROXY_RADIUS, RADIUS, point_at_angle
from server.bench.quantiles import tail

WHERES = ("free", "contact")
SWEEP_SAMPLES = 480      # one back-and-forth sweep: 8 s at 60 Hz
CONTACT_SWEEP_DEG = 60.0  # ±60° along the dome's arc: clear of the ground (z ≥ 0.33)
CONTACT_DEPTH = 0.003    # 3-4 mm inside the dilated dome (radius + proxy radius): firmly in contact
FREE_HEIGHT = 1.0        # 0.34 above the dilated dome's top, 0.94 above the ground
FREE_SWEEP = 0.5         # ±0.5 sideways
TAG = 1e-6               # per sample index mod TAG_PERIOD: distinct positions
TAG_PERIOD = 1000
BAND_MS = (35.0, 50.0)   # where Nagle + the peer's delayed ACK (40 ms on Linux) put a frame


def sample_position(where: str, k: int) -> tuple[float, float, float]:
    """The HIP of sample k. free: a sideways sweep 1 m above the ground, away from every object
    of the contact-angle scene, so frames leave on the 60 Hz cadence only. contact: a sweep along
    the dome, pressed into it, so the contact angle, and with it the tilt cue, changes with every
    sample and the loop publishes a frame in the tick that applies it."""
    phase = math.sin(2.0 * math.pi * k / SWEEP_SAMPLES)
    tag = (k % TAG_PERIOD) * TAG
    if where == "free":
        pos = (0.0, FREE_SWEEP * phase, FREE_HEIGHT + tag)
    elif where == "contact":
        pos = point_at_angle(CONTACT_SWEEP_DEG * phase, RADIUS + PROXY_RADIUS - CONTACT_DEPTH - tag)
    else:
        raise ValueError(f"where must be one of {', '.join(WHERES)}, got {where!r}")
    return (round(pos[0], 9), round(pos[1], 9), round(pos[2], 9))


def match_samples(sent: list[tuple[int, tuple]], frames: list[tuple[int, tuple, int]],
                  max_wait_ns: int = 1_000_000_000) -> list[tuple | None]:
    """For each sample (send ns, position): the first state frame received at or after the send
    whose hip equals the position, within `max_wait_ns`; None if no frame showed it (a later
    sample replaced it before a frame went out). `frames`: (receive ns, hip, tick ns), in the
    order received. The wait limit keeps a sample 1000 indices later, at the same position, out."""
    seen: dict[tuple, list[tuple]] = {}
    for frame in frames:
        seen.setdefault(tuple(frame[1]), []).append(frame)
    matches: list[tuple | None] = []
    for t_ns, pos in sent:
        shown = seen.get(tuple(pos), [])
        i = bisect.bisect_left(shown, t_ns, key=lambda f: f[0])
        matches.append(shown[i] if i < len(shown) and shown[i][0] - t_ns <= max_wait_ns else None)
    return matches


HALF = (("p50", 0.5), ("p99", 0.99))


def summarize(sent: list[tuple[int, tuple]], matches: list[tuple | None]) -> dict:
    """p50/p99/max of send → first frame showing the sample (ms), how many samples fell in the
    delayed-ACK band, how many no frame showed (`superseded`); and the split at the loop tick
    whose state the frame carries (its `t`, the same clock): send → tick, tick → received."""
    pairs = [(t, m) for (t, _), m in zip(sent, matches) if m is not None]
    latencies = sorted((m[0] - t) / 1e6 for t, m in pairs)
    to_tick = sorted((m[2] - t) / 1e6 for t, m in pairs)
    from_tick = sorted((m[0] - m[2]) / 1e6 for t, m in pairs)
    return {"samples": len(sent), "shown": len(latencies), "superseded": len(sent) - len(latencies),
            **tail(latencies, "", "_ms"),
            "in_35_50_ms": sum(1 for v in latencies if BAND_MS[0] <= v <= BAND_MS[1]),
            **tail(to_tick, "to_tick_", "_ms", HALF), **tail(from_tick, "tick_to_client_", "_ms", HALF)}
