"""Scenario switches against the loop's deadlines: the overruns that a burst of switches costs.

Starts a server of its own, resets the loop's timing window, asks for `switches` switches over
REST (positioning, hot wire and peg-in-hole in turn: the scenarios with the largest scenes) spaced
`every_s` apart, waits for the last one to be announced, and reads the loop's telemetry. Building
a scenario never runs inside a tick (server/loop/tick.py), so the overruns should be those of an
idle loop. Run: `python -m server.bench.switch_bench [--switches 100] [--every-ms 24]`.
"""

from __future__ import annotations

import argparse
import json
import time

from server.launcher import get_json, start_server, stop_server

SCENARIOS = ("positioning", "hot-wire", "peg-in-hole")


def run_switch_bench(switches: int = 100, every_s: float = 0.024, settle_s: float = 0.5,
                     start: str = "contact-angle") -> dict:
    if switches <= 0 or every_s < 0:
        raise ValueError("switches must be > 0 and every_s >= 0")
    proc, base = start_server(start)
    try:
        time.sleep(1.0)  # past the start-up's own late ticks
        get_json(base + "/api/telemetry/reset", "POST")
        asked = []
        start = time.monotonic()
        for i in range(switches):
            name = SCENARIOS[i % len(SCENARIOS)]
            asked.append(get_json(base + "/api/scenario", "POST",
                                  body={"name": name, "params": {}, "seed": i, "force": True}))
            time.sleep(max(0.0, start + (i + 1) * every_s - time.monotonic()))
        burst_s = time.monotonic() - start
        last = asked[-1]
        deadline = time.monotonic() + 10.0
        while (running := get_json(base + "/api/scenario")).get("seed") != last["seed"] or \
                running.get("id") != last["id"]:
            if time.monotonic() > deadline:
                raise RuntimeError(f"the last switch ({last['id']}, seed {last['seed']}) was never announced")
            time.sleep(0.02)
        time.sleep(settle_s)
        telemetry = get_json(base + "/api/telemetry")
    finally:
        stop_server(proc)
    return {"switches": switches, "burst_s": round(burst_s, 3), "overruns": telemetry["overruns"],
            "ticks": telemetry["ticks"], "period_p99_us": telemetry["period_p99_us"],
            "period_max_us": telemetry["period_max_us"], "tick_cost_max_us": telemetry["tick_cost_max_us"],
            "rt": telemetry["rt"], "last": [last["id"], last["seed"]]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="switch_bench", description=__doc__.splitlines()[0])
    parser.add_argument("--switches", type=int, default=100)
    parser.add_argument("--every-ms", type=float, default=24.0)
    parser.add_argument("--start", default="contact-angle", help="the scenario the server starts with")
    args = parser.parse_args(argv)
    print(json.dumps(run_switch_bench(args.switches, args.every_ms / 1e3, start=args.start)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
