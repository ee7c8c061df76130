"""Why was a loop tick late? The kernel's own tracer answers it (`bench loop --kernel-trace`).

The loop sleeps to an absolute deadline (clock_nanosleep, one hrtimer per tick). A period runs
long for one of three reasons, and only the kernel sees which:
- the timer interrupt came late: the CPU could not take it (on a virtual machine, the host had
  not run that vCPU; `idle` says the guest had nothing running there, so nothing in the guest
  held it up);
- the interrupt came on time but the loop got the CPU late: something in the guest held it
  (a non-preemptible kernel path, interrupts off, a task of equal or higher priority);
- the tick itself ran long: the guest's scheduler preempted it (`preempted`), or, if it did not,
  the time went where the guest's scheduler cannot see (the host stopped the vCPU, or a long
  kernel path inside the loop's own system call).

`LoopWakeTrace` (the adapter) records three tracepoints in a tracefs instance of its own, so it
leaves the global trace buffer alone: the loop arming its sleep timer (`hrtimer_start`, with the
deadline), the timer firing (`hrtimer_expire_entry`, with the time it ran), and the loop being
switched in and out (`sched_switch`). `parse_wakeups` and `summarize` are pure.
Needs root and tracefs (`mount -t tracefs nodev /sys/kernel/tracing`).
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

TRACEFS = Path("/sys/kernel/tracing")

_LINE = re.compile(r"^\s*(?P<comm>.+?)-(?P<pid>\d+)\s+\[(?P<cpu>\d+)\]\s+\S+\s+(?P<ts>\d+\.\d+): (?P<event>\w+): (?P<body>.*)$")
_FIELD = re.compile(r"(\w+)=(\S+)")


class KernelTraceUnavailable(RuntimeError):
    """The kernel's tracer cannot be used here (not root, no tracefs); the message says what to do."""


@dataclass(frozen=True)
class Wakeup:
    """One timed wake-up of the traced task and the run that followed; times in ns on CLOCK_MONOTONIC."""

    deadline_ns: int  # the absolute time the task asked to wake at
    fired_ns: int  # when the timer interrupt ran its handler
    cpu: int  # the CPU that took the interrupt
    idle: bool  # that CPU was idle when the interrupt came (nothing in the guest was in the way)
    switched_in_ns: int | None = None  # when the task got the CPU (None: woken on an idle CPU, no switch traced)
    slept_ns: int | None = None  # when it went back to sleep (None: not in the trace)
    preempted: bool = False  # the guest's scheduler took the CPU away from it during the run

    @property
    def timer_late_us(self) -> float:
        return (self.fired_ns - self.deadline_ns) / 1000

    @property
    def wake_to_run_us(self) -> float:
        return 0.0 if self.switched_in_ns is None else max(0.0, (self.switched_in_ns - self.fired_ns) / 1000)

    @property
    def run_us(self) -> float | None:
        """From getting the CPU to sleeping again: the tick as the kernel saw it, time lost included."""
        if self.slept_ns is None:
            return None
        return (self.slept_ns - (self.switched_in_ns or self.fired_ns)) / 1000


def parse_wakeups(text: str, pid: int) -> list[Wakeup]:
    """The timed wake-ups of task `pid` in a tracefs `trace` text (the three events above).

    A timer is known by its address: its latest `hrtimer_start` by `pid` gives the deadline
    (softexpires), its `hrtimer_expire_entry` the firing (`now`, the hrtimer's own clock). The
    `sched_switch` into `pid` after the firing is when it ran (event stamps must be on
    CLOCK_MONOTONIC: trace_clock "mono"; a wake on an idle CPU often has no switch in the trace
    and counts as running at once), the switch out of it in a sleeping state when the run ended,
    one in the running state (R) a preemption by the guest's scheduler."""
    armed: dict[str, int] = {}
    wakeups: list[Wakeup] = []
    current: dict | None = None  # the wake-up being followed
    running = False  # the task has run since that wake-up (a later switch-in is a return from a preemption)
    me = str(pid)
    for line in text.splitlines():
        match = _LINE.match(line)
        if match is None:
            continue
        event, body = match["event"], match["body"]
        fields = dict(_FIELD.findall(body))
        if current is not None and current["slept_ns"] is None:
            stamp = round(float(match["ts"]) * 1e9)
            if event == "sched_switch" and fields.get("next_pid") == me:
                if not running:
                    current["switched_in_ns"] = stamp
                running = True
            elif event == "sched_switch" and fields.get("prev_pid") == me:
                running = True
                if fields.get("prev_state", "").startswith("R"):
                    current["preempted"] = True
                else:
                    current["slept_ns"] = stamp
            elif match["pid"] == me:
                running = True
        if event == "hrtimer_start" and match["pid"] == me and fields.get("function") == "hrtimer_wakeup":
            # softexpires is the time asked for; expires adds the task's timer slack (0 at real-time priority)
            armed[fields["hrtimer"]] = int(fields.get("softexpires", fields["expires"]))
        elif event == "hrtimer_expire_entry" and fields.get("hrtimer") in armed:
            if current is not None:
                wakeups.append(Wakeup(**current))
            current = {"deadline_ns": armed.pop(fields["hrtimer"]), "fired_ns": int(fields["now"]),
                       "cpu": int(match["cpu"]), "idle": match["pid"] == "0",
                       "switched_in_ns": None, "slept_ns": None, "preempted": False}
            running = False
    if current is not None:
        wakeups.append(Wakeup(**current))
    return wakeups


def _quantile(values: list[float], q: float) -> float | None:
    return round(values[min(len(values) - 1, int(q * len(values)))], 1) if values else None


def summarize(wakeups: list[Wakeup], late_us: float = 500.0, long_run_us: float = 1000.0) -> dict:
    """Lateness of the traced wake-ups and, for those later than `late_us` (an overrun needs a
    start over 0.5 ms late at 1 kHz), which part made them late; runs longer than `long_run_us`
    (a whole period) and whether the guest's scheduler preempted them. The worst are listed."""
    timer = sorted(w.timer_late_us for w in wakeups)
    run = sorted(w.wake_to_run_us for w in wakeups)
    runs = sorted(w.run_us for w in wakeups if w.run_us is not None)
    long_runs = [w for w in wakeups if w.run_us is not None and w.run_us > long_run_us]
    late = [w for w in wakeups if w.timer_late_us + w.wake_to_run_us > late_us]
    by_timer = [w for w in late if w.timer_late_us >= w.wake_to_run_us]
    return {
        "traced_wakeups": len(wakeups),
        "timer_late_p50_us": _quantile(timer, 0.5), "timer_late_p99_us": _quantile(timer, 0.99),
        "timer_late_max_us": _quantile(timer, 1.0),
        "wake_to_run_p50_us": _quantile(run, 0.5), "wake_to_run_p99_us": _quantile(run, 0.99),
        "wake_to_run_max_us": _quantile(run, 1.0),
        "late_wakeups": len(late),
        "late_by_timer_interrupt": len(by_timer),
        "late_by_timer_interrupt_on_idle_cpu": sum(w.idle for w in by_timer),
        "late_by_scheduling": len(late) - len(by_timer),
        "late_wakeups_us": sorted((round(w.timer_late_us + w.wake_to_run_us) for w in late), reverse=True)[:20],
        "run_p50_us": _quantile(runs, 0.5), "run_p99_us": _quantile(runs, 0.99), "run_max_us": _quantile(runs, 1.0),
        "long_runs": len(long_runs),
        "long_runs_preempted_in_guest": sum(w.preempted for w in long_runs),
        "long_runs_us": sorted((round(w.run_us) for w in long_runs), reverse=True)[:20],
    }


class LoopWakeTrace:
    """Traces the timed wake-ups of one task in a tracefs instance of its own (context manager)."""

    # event → filters to try in turn (kernels before 6.2 have no `.function` symbol filter; the
    # parser selects what a coarser filter lets through)
    EVENTS = {
        "timer/hrtimer_start": ("common_pid == {pid} && function.function == hrtimer_wakeup", "common_pid == {pid}"),
        "timer/hrtimer_expire_entry": ("function.function == hrtimer_wakeup", "0"),  # "0": no filter
        "sched/sched_switch": ("prev_pid == {pid} || next_pid == {pid}",),
    }

    def __init__(self, pid: int, tracefs: Path | None = None, buffer_kb: int = 8192):
        """`buffer_kb` per CPU; the loop fills about 200 kB a second on the CPU it runs on."""
        self.pid = pid
        self.tracefs = tracefs or TRACEFS
        self.buffer_kb = buffer_kb
        self.instance = self.tracefs / "instances" / f"viestac-wake-{os.getpid()}-{pid}"
        self.text = ""
        self.lost_events = 0  # overwritten in the ring buffer: the trace then misses its oldest part

    @staticmethod
    def check(tracefs: Path | None = None) -> None:
        """Raise KernelTraceUnavailable, saying why and what to do, unless tracing can be used."""
        tracefs = tracefs or TRACEFS
        if not (tracefs / "instances").is_dir():
            raise KernelTraceUnavailable(
                f"no tracefs at {tracefs}: mount it (mount -t tracefs nodev {tracefs}) or leave out --kernel-trace")
        if not os.access(tracefs / "instances", os.W_OK):
            raise KernelTraceUnavailable(f"{tracefs}/instances is not writable: --kernel-trace needs root")

    @classmethod
    def usable(cls, tracefs: Path | None = None) -> bool:
        try:
            cls.check(tracefs)
            return True
        except KernelTraceUnavailable:
            return False

    def _write(self, relative: str, value: str) -> None:
        (self.instance / relative).write_text(value)

    def start(self) -> None:
        self.check(self.tracefs)
        try:
            self.instance.mkdir()
        except OSError as exc:
            raise KernelTraceUnavailable(f"cannot create the trace instance {self.instance}: {exc}") from exc
        try:
            self._write("buffer_size_kb", str(self.buffer_kb))
            self._write("trace_clock", "mono")  # event stamps on CLOCK_MONOTONIC, the hrtimers' clock
            for event, conditions in self.EVENTS.items():
                for condition in conditions:
                    try:
                        self._write(f"events/{event}/filter", condition.format(pid=self.pid))
                        break
                    except OSError:
                        continue
                self._write(f"events/{event}/enable", "1")
            self._write("tracing_on", "1")
        except BaseException:
            self._remove()
            raise

    def stop(self) -> list[Wakeup]:
        """Stop, read the trace, remove the instance; return the wake-ups."""
        try:
            self._write("tracing_on", "0")
            self.text = (self.instance / "trace").read_text()
            self.lost_events = sum(int(line.split(":")[1]) for stats in (self.instance / "per_cpu").glob("cpu*/stats")
                                   for line in stats.read_text().splitlines() if line.startswith("overrun:"))
        finally:
            self._remove()
        return parse_wakeups(self.text, self.pid)

    def _remove(self) -> None:
        try:
            self.instance.rmdir()
        except OSError:
            pass

    def __enter__(self) -> "LoopWakeTrace":
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        if self.instance.exists():
            self.stop()
