"""`bench loop --kernel-trace`: reading the kernel's own account of each loop wake-up."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from server import cli
from server.bench import kernel_trace, loop_bench
from server.bench.kernel_trace import (TRACEFS, KernelTraceUnavailable, LoopWakeTrace, Wakeup, parse_wakeups,
                                       summarize)

# Lines in tracefs's format (trace_clock mono), shaped after a real trace of the loop (pid 4340):
# 1) on time, woken on an idle CPU (no switch-in traced), runs 113 µs;
# 2) the timer interrupt 3.4 ms late on an idle CPU (the host had not run that vCPU); preempted
#    once by the guest's scheduler (R+), back 40 µs later: not a new switch-in;
# 3) the interrupt on time, but a task held the CPU 0.7 ms before the loop was switched in;
# 4) on time, but the run takes 1.45 ms with no preemption (time lost where the guest cannot see);
# plus noise the parser must ignore: another task's sleep timer, a tick timer armed in the
# loop's context, a switch between two other tasks.
TRACE = """\
# tracer: nop
#
          python-4340    [001] d..1. 32499.247859: hrtimer_start: hrtimer=00000000a1d19663 function=hrtimer_wakeup expires=32499248754777 softexpires=32499248754777 mode=ABS was_armed=0
          python-4340    [001] d..1. 32499.247860: hrtimer_start: hrtimer=00000000d110fdb3 function=tick_nohz_handler expires=32499252000000 softexpires=32499252000000 mode=ABS|PINNED|HARD was_armed=1
          python-4330    [001] d..1. 32499.247875: hrtimer_start: hrtimer=00000000ce0c0944 function=hrtimer_wakeup expires=32499268923575 softexpires=32499268873575 mode=ABS was_armed=0
          <idle>-0       [001] d.h1. 32499.248771: hrtimer_expire_entry: hrtimer=00000000a1d19663 function=hrtimer_wakeup now=32499248770723
          python-4340    [001] d..1. 32499.248872: hrtimer_start: hrtimer=00000000ff9508da function=hrtimer_wakeup expires=32499249754847 softexpires=32499249754847 mode=ABS was_armed=0
          python-4340    [001] d..2. 32499.248884: sched_switch: prev_comm=python prev_pid=4340 prev_prio=49 prev_state=S ==> next_comm=swapper/1 next_pid=0 next_prio=120
          <idle>-0       [001] d.h1. 32499.252000: hrtimer_expire_entry: hrtimer=00000000d110fdb3 function=tick_nohz_handler now=32499252000100
          <idle>-0       [001] d.h1. 32499.253142: hrtimer_expire_entry: hrtimer=00000000ff9508da function=hrtimer_wakeup now=32499253141422
          python-4340    [001] d..2. 32499.253160: sched_switch: prev_comm=python prev_pid=4340 prev_prio=49 prev_state=R+ ==> next_comm=migration/1 next_pid=19 next_prio=0
     migration/1-19      [001] d..2. 32499.253200: sched_switch: prev_comm=migration/1 prev_pid=19 prev_prio=0 prev_state=S ==> next_comm=python next_pid=4340 next_prio=49
          python-4340    [001] d..1. 32499.253250: hrtimer_start: hrtimer=0000000045668cc2 function=hrtimer_wakeup expires=32499253754800 softexpires=32499253754800 mode=ABS was_armed=0
          python-4340    [001] d..2. 32499.253260: sched_switch: prev_comm=python prev_pid=4340 prev_prio=49 prev_state=S ==> next_comm=swapper/1 next_pid=0 next_prio=120
 memfd:sealed-91-1508    [000] d..2. 32499.253300: sched_switch: prev_comm=memfd:sealed-91 prev_pid=1508 prev_prio=120 prev_state=S ==> next_comm=python next_pid=4330 next_prio=120
          python-4330    [001] d.h2. 32499.253770: hrtimer_expire_entry: hrtimer=0000000045668cc2 function=hrtimer_wakeup now=32499253769000
          python-4330    [001] d..2. 32499.254480: sched_switch: prev_comm=python prev_pid=4330 prev_prio=120 prev_state=R ==> next_comm=python next_pid=4340 next_prio=49
          python-4340    [001] d..1. 32499.254600: hrtimer_start: hrtimer=0000000011112222 function=hrtimer_wakeup expires=32499254754800 softexpires=32499254754800 mode=ABS was_armed=0
          python-4340    [001] d..2. 32499.254650: sched_switch: prev_comm=python prev_pid=4340 prev_prio=49 prev_state=S ==> next_comm=python next_pid=4330 next_prio=120
          <idle>-0       [001] d.h1. 32499.254760: hrtimer_expire_entry: hrtimer=0000000011112222 function=hrtimer_wakeup now=32499254760000
          python-4340    [001] d..1. 32499.256200: hrtimer_start: hrtimer=0000000033334444 function=hrtimer_wakeup expires=32499256754800 softexpires=32499256754800 mode=ABS was_armed=0
          python-4340    [001] d..2. 32499.256210: sched_switch: prev_comm=python prev_pid=4340 prev_prio=49 prev_state=S ==> next_comm=swapper/1 next_pid=0 next_prio=120
"""


def test_each_timed_wakeup_is_found_with_its_deadline_firing_switch_in_and_sleep():
    wakeups = parse_wakeups(TRACE, 4340)
    assert wakeups == [
        Wakeup(deadline_ns=32499248754777, fired_ns=32499248770723, cpu=1, idle=True, slept_ns=32499248884000),
        Wakeup(deadline_ns=32499249754847, fired_ns=32499253141422, cpu=1, idle=True, slept_ns=32499253260000,
               preempted=True),
        Wakeup(deadline_ns=32499253754800, fired_ns=32499253769000, cpu=1, idle=False,
               switched_in_ns=32499254480000, slept_ns=32499254650000),
        Wakeup(deadline_ns=32499254754800, fired_ns=32499254760000, cpu=1, idle=True, slept_ns=32499256210000),
    ]
    assert wakeups[0].timer_late_us == pytest.approx(15.946)
    assert wakeups[0].wake_to_run_us == 0.0  # woken on an idle CPU: it runs at once
    assert wakeups[0].run_us == pytest.approx(113.277)
    assert wakeups[1].wake_to_run_us == 0.0  # the return from its preemption is not its start
    assert wakeups[2].wake_to_run_us == pytest.approx(711.0) and wakeups[2].run_us == pytest.approx(170.0)
    assert parse_wakeups(TRACE, 4330) == []  # its timer never fired in the trace
    assert parse_wakeups("# tracer: nop\ngarbage line\n", 4340) == []


def test_late_wakeups_and_long_runs_are_put_down_to_their_cause():
    summary = summarize(parse_wakeups(TRACE, 4340))
    assert summary["traced_wakeups"] == 4
    assert summary["late_wakeups"] == 2
    assert summary["late_by_timer_interrupt"] == 1 and summary["late_by_timer_interrupt_on_idle_cpu"] == 1
    assert summary["late_by_scheduling"] == 1
    assert summary["late_wakeups_us"] == [3387, 725]  # worst first
    assert summary["timer_late_max_us"] == pytest.approx(3386.6)
    assert summary["wake_to_run_max_us"] == pytest.approx(711.0)
    assert summary["long_runs"] == 1 and summary["long_runs_preempted_in_guest"] == 0
    assert summary["long_runs_us"] == [1450] and summary["run_max_us"] == pytest.approx(1450.0)
    assert summarize([])["traced_wakeups"] == 0 and summarize([])["timer_late_p99_us"] is None


def test_a_machine_without_tracefs_gets_a_clear_refusal(tmp_path):
    with pytest.raises(KernelTraceUnavailable, match="no tracefs"):
        LoopWakeTrace.check(tmp_path / "missing")
    assert not LoopWakeTrace.usable(tmp_path / "missing")


def test_bench_loop_refuses_kernel_trace_up_front_without_tracefs(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(kernel_trace, "TRACEFS", tmp_path / "missing")
    started = []
    monkeypatch.setattr(loop_bench, "start_server", lambda *a, **k: started.append(a))
    assert cli.main(["bench", "loop", "--seconds", "1", "--kernel-trace"]) == 2
    err = capsys.readouterr().err
    assert "no tracefs" in err and "mount -t tracefs" in err
    assert started == []  # refused before any server started



SLEEPER = """
import time
deadline = time.monotonic_ns() + 300_000_000  # after the tracer is on
for _ in range(200):
    deadline += 1_000_000
    time.sleep(max(0, deadline - time.monotonic_ns()) / 1e9)
"""


@pytest.mark.skipif(not LoopWakeTrace.usable(), reason="needs root and tracefs at /sys/kernel/tracing")
def test_a_live_trace_of_a_1_khz_sleeper_sees_its_wakeups_and_leaves_no_instance_behind():
    sleeper = subprocess.Popen([sys.executable, "-c", SLEEPER])
    trace = LoopWakeTrace(sleeper.pid)
    trace.start()
    assert trace.instance.is_dir()
    sleeper.wait(timeout=30)
    wakeups = trace.stop()
    assert not trace.instance.exists()
    summary = summarize(wakeups)
    print(f"\n{summary}")
    assert 190 <= summary["traced_wakeups"] <= 201  # its 200 sleeps (and perhaps one of start-up)
    assert all(w.fired_ns >= w.deadline_ns for w in wakeups)  # a timer never fires early
    assert summary["timer_late_p50_us"] >= 0
    assert not any(name.startswith(f"viestac-wake-{os.getpid()}-") for name in os.listdir(TRACEFS / "instances"))
