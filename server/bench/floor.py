"""The machine's floor under the loop's tick (`viestac bench floor`; `viestac bench loop` measures
it first, as the baseline of the same run).

What a tick costs on this machine before it does any work of its own, in the loop's own setting:
a process pinned where the server's CPU plan pins the loop (server/cpu_plan.py), at the loop's
real-time priority, sleeping to 1 ms deadlines with the loop's scheduler and clock, its startup
objects frozen out of the collector's sight as the loop's are. Two patterns, one after the other:

- `idle`: a tick that only reads the clock when it wakes and when it ends. Its tail is what the
  machine adds to any tick (an interrupt, the host taking the virtual CPU away mid-tick).
- `sends`: every `publish_every`-th tick also hands one record to each of two processes blocked in
  `recv` on the other CPUs of the plan. That is the least a tick that publishes does: its cue to
  the device host's feed and its state record to the hub, each waking a process on another CPU
  (server/loop/process.py). The records are packed beforehand, so only the sends are timed.

The loop bench's tick cost (the same interval: wake-up to after the last send) cannot be below
this floor's same percentile; the difference is the tick's own work. docs/performance.md reports
both. Each pattern runs for `seconds` (1000 ticks a second: ≥ 1000 samples for its p99) and
every percentile is the nearest rank of all its ticks, the p99 with its confidence interval
(server/bench/quantiles.py).

Run in a child process of its own (`python -m server.bench.floor`), so the caller keeps its
priority and CPUs; the two receivers are forked from it and say how many records they got.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import socket
import subprocess
import sys

import msgpack

from server import ipc
from server.bench.quantiles import tail
from server.cpu_plan import MODES, CpuPlan, check_mode, pin_process, plan_cpus
from server.loop.clock import MonotonicClock
from server.loop.process import LoopConfig, try_realtime
from server.loop.scheduler import DeadlineScheduler

PUBLISH_EVERY = 6  # about one tick in six publishes at 64 viewers with two 120 Hz trackers (docs/performance.md)
CUE_RECORD_BYTES = 128  # a cue record (["cues", tick, sent_ns, [cue]]) is ~100 bytes
STATE_RECORD_BYTES = 1024  # a contact-angle state record is ~1 KB
TICK_NS = 1_000_000


def check(seconds: float, publish_every: int) -> None:
    if not seconds > 0:
        raise ValueError(f"seconds must be > 0, got {seconds}")
    if publish_every < 1:
        raise ValueError(f"publish_every must be >= 1, got {publish_every}")


def run_floor(seconds: float = 3.0, loop_cpu: str = "auto", publish_every: int = PUBLISH_EVERY) -> dict:
    """Measure the floor in a child process (module doc); its result, keys prefixed `floor_`."""
    check(seconds, publish_every)
    check_mode(loop_cpu)
    proc = subprocess.run([sys.executable, "-m", "server.bench.floor", "--seconds", str(seconds),
                           "--loop-cpu", loop_cpu, "--publish-every", str(publish_every)],
                          capture_output=True, text=True, timeout=60 + 4 * seconds)
    if proc.returncode != 0:
        raise RuntimeError(f"the floor measurement failed (exit {proc.returncode}): {proc.stderr.strip()[-800:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _receiver(sock: socket.socket, cpus: frozenset[int]) -> None:
    """A forked child: block in recv as the hub and the device host's feed do; at the end of the
    stream, answer with the number of records received."""
    try:
        pin_process(cpus)
        sock.setblocking(True)
        count = 0
        while True:
            if not sock.recv(ipc.MAX_RECORD_BYTES):
                break
            count += 1
        sock.send(msgpack.packb(count))
    finally:
        os._exit(0)


def _start_receivers(plan: CpuPlan, n: int = 2) -> list[tuple[int, socket.socket]]:
    """(pid, our end) of `n` receivers."""
    receivers = []
    for _ in range(n):
        ours, theirs = ipc.channel_pair()
        pid = os.fork()
        if pid == 0:
            ours.close()
            _receiver(theirs, plan.others)
        theirs.close()
        receivers.append((pid, ours))
    return receivers


def _counts(receivers: list[tuple[int, socket.socket]]) -> list[int]:
    """End each receiver's stream and collect how many records it got."""
    counts = []
    for pid, end in receivers:
        end.shutdown(socket.SHUT_WR)
        end.settimeout(10)
        counts.append(msgpack.unpackb(end.recv(64)))
        end.close()
        os.waitpid(pid, 0)
    return counts


def _pattern(clock: MonotonicClock, ticks: int, ends: list[socket.socket], records: list[bytes],
             publish_every: int | None) -> list[int]:
    """Run `ticks` ticks, sending on ticks 0, publish_every, ... (None: never); each tick's cost, ns."""
    costs = [0] * ticks
    scheduler = DeadlineScheduler(clock, TICK_NS)
    for i in range(ticks):
        start, _ = scheduler.wait_next()
        if publish_every is not None and i % publish_every == 0:
            for end, record in zip(ends, records):
                end.send(record)
        costs[i] = clock.now_ns() - start
    return costs


def _us(values: list[int]) -> list[float]:
    return sorted(v / 1000 for v in values)


def measure(seconds: float, loop_cpu: str, publish_every: int) -> dict:
    """The child's work (module doc). Changes this process's CPUs and priority."""
    check(seconds, publish_every)
    plan = plan_cpus(os.sched_getaffinity(0), loop_cpu)
    receivers = _start_receivers(plan)
    ends = [end for _, end in receivers]
    if plan.loop is not None:
        pin_process({plan.loop})
    rt = try_realtime(LoopConfig.rt_priority) is None
    records = [msgpack.packb(["cues", 0, 0, b"\0" * CUE_RECORD_BYTES]),
               msgpack.packb(["state", b"\0" * STATE_RECORD_BYTES])]
    clock = MonotonicClock()
    ticks = int(seconds * 1000)
    gc.collect()
    gc.freeze()
    _pattern(clock, 200, ends, records, None)  # settle: the first ticks after start-up are not the floor
    idle = _pattern(clock, ticks, ends, records, None)
    sends = _pattern(clock, ticks, ends, records, publish_every)
    sending = sends[::publish_every]
    received = _counts(receivers)
    points = (("p50", 0.5), ("p99", 0.99), ("max", 1.0))
    return {
        **tail(_us(idle), "floor_idle_", "_us", points),
        **tail(_us(sends), "floor_sends_", "_us", points),
        **tail(_us(sending), "floor_sending_tick_", "_us", (("p50", 0.5), ("p99", 0.99))),
        "floor_ticks": ticks, "floor_sending_ticks": len(sending), "floor_publish_every": publish_every,
        "floor_records_received": received, "floor_rt": rt, "floor_cpus": plan.to_dict(),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="viestac-floor", description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0, help="per pattern (1000 ticks a second)")
    parser.add_argument("--loop-cpu", choices=MODES, default="auto")
    parser.add_argument("--publish-every", type=int, default=PUBLISH_EVERY)
    args = parser.parse_args(argv)
    try:
        result = measure(args.seconds, args.loop_cpu, args.publish_every)
    except ValueError as exc:
        parser.error(str(exc))
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
