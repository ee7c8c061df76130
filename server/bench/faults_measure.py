"""The pure parts of `viestac bench faults`: reading the emulators' actuator timelines, the
recovery times, frames and samples lost, statistics and the judgement against the acceptance of
docs/reliability.md. No I/O: server/bench/faults.py records, this module decides.

Every time is CLOCK_MONOTONIC of the one machine: the bench's own stamps (ns), the emulators'
timeline rows (µs) and the loop's state `t` (s) compare directly.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass

from server.bench.quantiles import percentile
from server.hub.frame_ceiling import BURST, frames_per_s
from server.loop.cadence import STATE_HZ

# The acceptance (docs/reliability.md "Acceptance").
LOOP_FIRST_STATE_MS = 1500.0   # loop killed -> first state frame on the participant's socket again
ACTUATORS_OFF_MS = 50.0        # loop killed -> every actuator off
RECONNECT_MS = 1000.0          # device emulator killed and restarted -> connected again
DEGRADED_MS = 100.0            # a process or device fault -> /api/health (or the `health` message) degraded
# Bounds the bench applies to the faults the issue names without a number (docs/reliability.md).
TRACKER_LOSS_OFF_MS = 1000.0   # the participant's tracker is gone -> no contact cue stays on
TRACKER_TTL_MS = 50.0          # the bench participant's sample ttl during the tracker-loss fault
# A silent tracker is known lost only when its ttl has passed; from then on, as a process fault.
TRACKER_LOSS_DEGRADED_MS = TRACKER_TTL_MS + DEGRADED_MS
FRAME_GROWTH_MAX = 2.0         # a key flood may not grow the viewers' median frame more than this
FRAME_RATE_KEEP = 0.8          # floods and slow readers: viewers keep this share of their frame rate
RESUME_MS = 1000.0             # huge values: state frames from ticks after the bad samples within this
HEALTH_ANSWER_MS = 100.0       # floods and slow readers: /api/health answers within this (issue 35)
FRAME_CEILING_HZ = frames_per_s(STATE_HZ) + BURST  # tracker jitter: a viewer gets at most this (docs/protocol.md)


@dataclass(frozen=True)
class TimelineRow:
    t_us: int
    channel: int
    on: bool


def actuator_on(row: dict) -> bool:
    """Whether one timeline row (docs/devices.md, devices/emulator.py TIMELINE_COLUMNS) leaves its
    channel doing something the wearer feels: a tilt, or a vibration pattern with intensity.
    Temperature and friction layers are not judged (no device of the simulated rig shows them)."""
    magnitude = float(row.get("magnitude_pct") or 0)
    intensity = float(row.get("intensity_pct") or 0)
    return magnitude > 0 or (row.get("mode", "off") != "off" and intensity > 0)


def parse_timeline(text: str) -> list[TimelineRow]:
    """Rows of an emulator's timeline CSV. A row cut short by a kill (the last, unflushed line)
    is skipped."""
    rows = []
    for raw in csv.DictReader(io.StringIO(text)):
        if None in raw.values():
            continue  # fewer fields than the header
        try:
            rows.append(TimelineRow(int(raw["t_us"]), int(raw["channel"]), actuator_on(raw)))
        except (KeyError, TypeError, ValueError):
            continue
    return rows


def all_off_after(timelines: dict[str, list[TimelineRow]], since_us: int,
                  until_us: int | None = None) -> tuple[bool, int | None]:
    """(held, off_us): whether any channel of any device was on at `since_us`, and the first
    time at or after it at which every channel of every device was off (None: never, up to
    `until_us`). `held` False means the fault found nothing on, so there was nothing to turn off."""
    state: dict[tuple[str, int], bool] = {}
    later: list[tuple[int, str, int, bool]] = []
    for device, rows in timelines.items():
        for row in sorted(rows, key=lambda r: r.t_us):
            if row.t_us <= since_us:
                state[(device, row.channel)] = row.on
            elif until_us is None or row.t_us <= until_us:
                later.append((row.t_us, device, row.channel, row.on))
    held = any(state.values())
    if not held:
        return False, None
    for t_us, device, channel, on in sorted(later):
        state[(device, channel)] = on
        if not any(state.values()):
            return True, t_us
    return True, None


def frames_lost(recv_ns: list[int], start_ns: int, end_ns: int, rate_hz: float) -> int:
    """State frames missing from a stream that should arrive at `rate_hz` at least, between
    start and end: every gap longer than one period counts the periods it skipped. Frames of
    changed cues come between the cadence's and never make up for a gap."""
    period_ns = 1e9 / rate_hz
    inside = [t for t in recv_ns if start_ns <= t <= end_ns]
    edges = [start_ns, *inside, end_ns]
    return sum(max(0, round((b - a) / period_ns) - 1) for a, b in zip(edges, edges[1:]))


def rate_hz(recv_ns: list[int], start_ns: int, end_ns: int) -> float | None:
    if end_ns <= start_ns:
        return None
    return round(sum(1 for t in recv_ns if start_ns <= t < end_ns) / ((end_ns - start_ns) / 1e9), 2)


def median(values: list[float]) -> float | None:
    return percentile(sorted(values), 0.5)


def health_times(samples: list[tuple[int, str]], fault_ns: int,
                 end_ns: int | None = None) -> tuple[float | None, float | None]:
    """(ms from the fault to the first `degraded`, ms from the fault to the first `ok` after
    that), from (t_ns, status) observations in time order; None where it did not happen."""
    degraded_ns = ok_ns = None
    for t_ns, status in samples:
        if t_ns < fault_ns or (end_ns is not None and t_ns > end_ns):
            continue
        if degraded_ns is None:
            if status == "degraded":
                degraded_ns = t_ns
        elif status == "ok":
            ok_ns = t_ns
            break
    return tuple(None if t is None else round((t - fault_ns) / 1e6, 3) for t in (degraded_ns, ok_ns))


def expected_samples(started_tick: int | None, ended_tick: int | None, every: int) -> int | None:
    """Trajectory rows a trial from started_tick to ended_tick should hold: one at every tick that
    is a multiple of `every` (the recorder's decimation, docs/data.md). None when the ticks do
    not make a trial (missing, or ended before started: the tick clock went back)."""
    if started_tick is None or ended_tick is None or ended_tick < started_tick:
        return None
    return ended_tick // every - (started_tick - 1) // every


def ticks_agree(started_tick: int | None, ended_tick: int | None, tick_hz: float, wall_s: float,
                slack_s: float = 0.25) -> bool:
    """Whether a trial's ticks span what its wall-clock times do (within `slack_s` + 5 %: the
    trial takes effect a tick after the engine stamps its start). They do not when the tick clock
    went back or jumped in the trial (a restarted loop counting from 0): then the ticks cannot
    tell how many samples the trial should have, and the wall clock does."""
    expected = expected_samples(started_tick, ended_tick, 1)
    if expected is None:
        return False
    return abs((ended_tick - started_tick) / tick_hz - wall_s) <= slack_s + 0.05 * wall_s


def stats(values: list[float | None]) -> dict:
    """p50 and max of the measured values, how many there were and how many did not happen."""
    got = sorted(v for v in values if v is not None)
    return {"p50": percentile(got, 0.5), "max": percentile(got, 1.0), "n": len(got),
            "missing": sum(1 for v in values if v is None)}


@dataclass(frozen=True)
class Check:
    """One acceptance line: `value` (the worst repetition) against `limit`; passed None = not judged."""
    name: str
    limit: float | str
    value: float | int | str | None
    passed: bool | None

    def to_dict(self) -> dict:
        return {"check": self.name, "limit": self.limit, "value": self.value, "pass": self.passed}


def at_most(name: str, values: list[float | None], limit: float, required: bool = True) -> Check:
    """Every repetition measured and ≤ limit. A missing value (it never happened) fails when
    `required`, else the check is not judged."""
    if not values:
        return Check(name, limit, None, None)
    if any(v is None for v in values):
        return Check(name, limit, None, False if required else None)
    worst = max(values)
    return Check(name, limit, worst, worst <= limit)


def at_least(name: str, values: list[float | None], limit: float) -> Check:
    if not values:
        return Check(name, limit, None, None)
    if any(v is None for v in values):
        return Check(name, limit, None, False)
    worst = min(values)
    return Check(name, limit, worst, worst >= limit)


def all_true(name: str, values: list[bool | None]) -> Check:
    if not values:
        return Check(name, "all", None, None)
    bad = sum(1 for v in values if v is not True)
    return Check(name, "all", f"{len(values) - bad}/{len(values)}", bad == 0)


# Which measurements each fault is judged on (docs/reliability.md). A process or device fault
# must show in health; an input fault must be refused at the edge without harming anyone else.
PROCESS_FAULTS = ("loop_kill", "device_host_kill", "emulator_restart", "device_unplug")
HEALTH_FAULTS = PROCESS_FAULTS + ("tracker_loss",)  # must show in health: degraded, then ok again
FLOOD_FAULTS = ("key_flood", "tracker_flood", "tracker_jitter", "slow_readers")  # /api/health must stay quick


def judge(kind: str, reps: list[dict]) -> list[Check]:
    """The acceptance checks of one fault kind over its repetitions' measurements."""
    def col(key: str) -> list:
        return [r.get(key) for r in reps]

    checks: list[Check] = []
    if kind == "loop_kill":
        checks.append(at_most("first state frame again (ms)", col("first_state_ms"), LOOP_FIRST_STATE_MS))
        checks.append(at_most("actuators off after the kill (ms)",
                              [r.get("actuators_off_ms") for r in reps if r.get("held")], ACTUATORS_OFF_MS))
        checks.append(all_true("loop process replaced", col("loop_pid_changed")))
    elif kind == "device_host_kill":
        checks.append(at_most("actuators off after the kill (ms)",
                              [r.get("actuators_off_ms") for r in reps if r.get("held")], ACTUATORS_OFF_MS))
        checks.append(all_true("devices connected again", [r.get("reconnect_ms") is not None for r in reps]))
    elif kind in ("emulator_restart", "device_unplug"):
        checks.append(at_most("connected again after the new device (ms)", col("reconnect_ms"), RECONNECT_MS))
        checks.append(all_true("the held cue shown again by the new device", col("cue_reapplied")))
    elif kind == "tracker_loss":
        checks.append(at_most("cue off after the tracker left (ms)",
                              [r.get("actuators_off_ms") for r in reps if r.get("held")], TRACKER_LOSS_OFF_MS))
        checks.append(all_true("health names tracker_lost", col("tracker_lost_reported")))
    elif kind == "key_flood":
        checks.append(at_most("viewer frame median growth (x)", col("frame_growth"), FRAME_GROWTH_MAX))
    elif kind in ("tracker_flood", "tracker_jitter", "slow_readers"):
        checks.append(at_least("viewer frame rate kept (share)", col("rate_kept"), FRAME_RATE_KEEP))
        if kind == "tracker_jitter":
            checks.append(at_most("viewer frames a second (the ceiling)", col("viewer_hz_during"), FRAME_CEILING_HZ))
    elif kind in ("huge_values_ws", "huge_values_udp"):
        checks.append(at_most("state frames resume (ms)", col("resume_ms"), RESUME_MS))
        checks.append(all_true("recovered on the next sane sample", col("recovered")))
        checks.append(at_most("health degraded while frames stopped (ms)",
                              [r.get("degraded_ms") for r in reps if not r.get("recovered")], DEGRADED_MS))
    elif kind == "bad_frames":
        checks.append(all_true("connection open with an error reply", col("stayed_open")))
    if kind in FLOOD_FAULTS:
        checks.append(at_most("/api/health answered (ms, slowest)", col("health_slowest_ms"), HEALTH_ANSWER_MS))
    if kind in HEALTH_FAULTS:
        checks.append(at_most("health degraded (ms)", col("degraded_ms"),
                              TRACKER_LOSS_DEGRADED_MS if kind == "tracker_loss" else DEGRADED_MS))
        checks.append(all_true("health ok again", [r.get("ok_ms") is not None for r in reps]))
    else:
        checks.append(all_true("health ok after", col("ok_after")))
    checks.append(at_most("completed-trial samples lost", col("samples_lost"), 0, required=False))
    return checks


def passed(checks: list[Check]) -> bool:
    """A fault passes when no judged check failed."""
    return all(c.passed is not False for c in checks)


def table(report: dict) -> str:
    """The human-readable report: one line per fault and check."""
    lines = [f"viestac bench faults: {report['repeat']} repetitions, {report['seconds']} s, "
             f"overall {'PASS' if report['pass'] else 'FAIL'}"]
    if report.get("error"):
        lines.append(f"the run failed: {report['error']}")
    for kind, fault in report["faults"].items():
        lines.append(f"{kind:18s} {'pass' if fault['pass'] else 'FAIL'}")
        for c in fault["checks"]:
            mark = {True: "ok ", False: "BAD", None: " - "}[c["pass"]]
            lines.append(f"    {mark} {c['check']:44s} {c['value']!s:>10s}  (limit {c['limit']})")
        summary = ", ".join(f"{k} p50 {v['p50']} max {v['max']}" for k, v in fault["times_ms"].items()
                            if v["n"])
        if summary:
            lines.append(f"        times (ms): {summary}")
        for note in fault.get("notes", []):
            lines.append(f"        note: {note}")
    lines.append(f"samples: {report['samples']}")
    return "\n".join(lines)
