"""The loop process for real (a subprocess on a mailbox): a scenario switch takes effect in a later
tick than the one that received it (built off the tick), and a restarted loop continues the
tick and frame count it is given."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time

from server import ipc
from server.loop.process import LoopConfig
from server.ipc.records import FROM_LOOP, Input, Stop, SwitchScenario
from tests.ipc import sent as array_of


def start_loop(config: LoopConfig, doorbell: ipc.Doorbell | None = None) -> tuple[subprocess.Popen, socket.socket]:
    ours, theirs = ipc.channel_pair()
    bell = ["--doorbell", str(doorbell.fd)] if doorbell is not None else []
    proc = subprocess.Popen([sys.executable, "-m", "server.loop.process", "--fd", str(theirs.fileno()), *bell,
                             "--config", config.to_json()],
                            pass_fds=(theirs.fileno(), *([doorbell.fd] if doorbell is not None else [])))
    theirs.close()
    return proc, ours


def records_until(sock: socket.socket, done, timeout_s: float = 20.0) -> list[list]:
    seen: list[list] = []
    deadline = time.monotonic() + timeout_s
    while not done(seen):
        assert time.monotonic() < deadline, f"timed out; last records: {[r[0] for r in seen[-10:]]}"
        try:
            seen.extend(map(array_of, ipc.drain(sock, FROM_LOOP)))
        except ipc.PeerClosed:
            raise AssertionError("the loop process exited") from None
        time.sleep(0.002)
    return seen


def stop(proc: subprocess.Popen, sock: socket.socket) -> None:
    ipc.send_record(sock, Stop())
    try:
        proc.wait(5)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    sock.close()


def test_a_switch_is_installed_in_a_later_tick_than_the_one_that_received_it():
    proc, sock = start_loop(LoopConfig(realtime=False))
    try:
        records_until(sock, lambda seen: any(r[0] == "state" for r in seen))
        # The key rides in the same mailbox drain: its event names the tick that applied the switch record.
        assert ipc.send_record(sock, SwitchScenario("positioning", {}, 0))
        assert ipc.send_record(sock, Input(1, "space", "press"))
        seen = records_until(sock, lambda seen: any(r[0] == "scenario" for r in seen))
        key_tick = next(e["tick"] for r in seen if r[0] == "state" for e in r[1]["events"] if e["name"] == "input")
        scene_at = next(i for i, r in enumerate(seen) if r[0] == "scene")
        announced = next(r[1] for r in seen if r[0] == "scenario")
        assert announced["id"] == "positioning-v1" and seen[scene_at][1]["name"] != "contact-angle"
        assert announced["tick"] > key_tick, "the switch was not built inside the tick that received it"
        old_scene = next(r[1]["scene"] for r in seen if r[0] == "state")
        assert all(r[1]["scene"] == old_scene for r in seen[:scene_at] if r[0] == "state"), \
            "the running scenario went on until the new one was installed"
    finally:
        stop(proc, sock)


def test_a_loop_given_a_start_tick_and_frame_continues_from_them():
    proc, sock = start_loop(LoopConfig(realtime=False, start_tick=123_456, start_frame=789))
    try:
        seen = records_until(sock, lambda seen: sum(r[0] == "state" for r in seen) >= 3)
        announced = next(r[1] for r in seen if r[0] == "scenario")
        states = [r[1] for r in seen if r[0] == "state"]
        assert announced["tick"] == 123_456
        assert states[0]["tick"] >= 123_456 and states[0]["frame"] == 790
        assert [s["tick"] for s in states] == sorted(s["tick"] for s in states)
    finally:
        stop(proc, sock)


def test_a_loop_that_cannot_pin_itself_runs_unpinned_and_says_so():
    unusable = max(os.sched_getaffinity(0)) + 4096  # no such CPU: sched_setaffinity refuses it
    proc, sock = start_loop(LoopConfig(realtime=False, cpu=unusable))
    try:
        seen = records_until(sock, lambda seen: any(r[0] == "state" for r in seen))
        hello = next(r[1] for r in seen if r[0] == "hello")
        warnings = [r[2] for r in seen if r[0] == "log" and r[1] == "warning"]
        assert hello["cpu"] is None
        assert any(f"not pinned to CPU {unusable}" in text for text in warnings), warnings
        assert os.sched_getaffinity(proc.pid) == os.sched_getaffinity(0)
    finally:
        stop(proc, sock)


def input_ticks(seen: list[list], key: str) -> list[int]:
    """The ticks of the `input` events of `key` in the state records seen."""
    return [e["tick"] for r in seen if r[0] == "state" for e in r[1]["events"] if e["name"] == "input" and e["key"] == key]


def test_a_loop_with_a_doorbell_reads_what_it_was_rung_for_and_loses_nothing():
    bell = ipc.Doorbell()
    proc, sock = start_loop(LoopConfig(realtime=False), bell)
    try:
        seen = records_until(sock, lambda seen: any(r[0] == "state" for r in seen))
        assert ipc.send_record(sock, Input(1, "unrung", "press"))  # in the socket, not rung for: waits
        seen = records_until(sock, lambda seen: sum(r[0] == "state" for r in seen) >= 6)
        assert input_ticks(seen, "unrung") == []
        bell.ring()
        assert ipc.send_record(sock, Input(1, "rung", "press"))
        bell.ring()
        seen = records_until(sock, lambda seen: input_ticks(seen, "rung"))
        assert input_ticks(seen, "unrung") == input_ticks(seen, "rung")  # both in the tick after the rings
        bell.ring()  # a count ahead of the socket (as a new loop reading an old count): one empty drain
        seen = records_until(sock, lambda seen: sum(r[0] == "state" for r in seen) >= 3)
        assert ipc.send_record(sock, Input(1, "after", "press"))
        bell.ring()
        records_until(sock, lambda seen: input_ticks(seen, "after"))
        # more than one drain takes: the rest waits for the next tick, none is lost, in order
        sent, before = 0, []
        while sent < ipc.DRAIN_LIMIT + 200:
            if ipc.send_record(sock, Input(1, "flood", "press", sent)):
                bell.ring()
                sent += 1
            else:
                before.extend(map(array_of, ipc.drain(sock, FROM_LOOP)))  # the loop's records fill our end meanwhile: read them
        seen = before + records_until(sock, lambda s: len(input_ticks(before + s, "flood")) >= sent)
        values = [e["value"] for r in seen if r[0] == "state" for e in r[1]["events"] if e.get("key") == "flood"]
        assert values == list(range(sent)) and len(set(input_ticks(seen, "flood"))) >= 2
    finally:
        stop(proc, sock)
        bell.close()
