"""Driving a Simulation like a scripted tracker: the helpers the positioning-task tests share."""

from __future__ import annotations


def drive(sim, points) -> list:
    """One tick per HIP point; the tick results."""
    out = []
    for p in points:
        sim.set_hip(p)
        out.append(sim.step())
    return out


def line(a, b, n: int) -> list[tuple[float, float, float]]:
    """n points from a to b (a excluded, b the last)."""
    return [tuple(a[i] + (b[i] - a[i]) * k / n for i in range(3)) for k in range(1, n + 1)]


def finished(results) -> list[tuple[int, dict]]:
    """(tick, metrics) of every tick whose output says the trial ended."""
    return [(r.tick, r.output.finished) for r in results if r.output.finished is not None]


def metrics_of(event: dict) -> dict:
    """A trial_done event's fields without those the loop stamps on every event."""
    return {k: v for k, v in event.items() if k not in ("name", "tick", "t")}
