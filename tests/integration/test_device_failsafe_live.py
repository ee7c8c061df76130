"""Fail safe in depth, live, read off the emulators' actuator timelines (CLOCK_MONOTONIC µs, the
clock of time.monotonic_ns() here):

- the loop process killed with SIGKILL while a tilt is held: the device host's feed hears nothing
  on the cue channel and turns the FerroVibe flat within 50 ms of the kill (devices/feed.py);
- the device host process killed: nothing writes to the device any more, and the firmware's own
  watchdog turns it flat at its timeout after the last frame (docs/device-protocol.md §2);
- a device emulator killed and started again at the same link: connected and identified again
  within 1 s."""

from __future__ import annotations

import csv
import math
import os
import pickle
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import msgpack
import pytest

from devices.emulator import Emulator
from devices.manager import DeviceConfig
from devices.ports import PortSpec
from devices.profiles import profile_by_model
from devices.protocol import WATCHDOG_MS
from devices.rig import emulator_command
from server import ipc
from tests.live_server import get_json, start_server, stop_server
from server.ipc.records import Cues

ROOT = Path(__file__).resolve().parents[2]
IN_CONTACT = [0.0, -(0.66 - 0.003) * math.sin(math.radians(30)), (0.66 - 0.003) * math.cos(math.radians(30))]


def timeline(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def wait_for(predicate, timeout_s: float, message: str):
    deadline = time.monotonic() + timeout_s
    while not (value := predicate()):
        if time.monotonic() > deadline:
            raise AssertionError(message)
        time.sleep(0.01)
    return value


def hold_contact(udp: str, stop: threading.Event) -> None:
    """A tracker bridge holding the HIP in the contact-angle dome: the tilt cue stays on."""
    host, port = udp.rsplit(":", 1)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        seq = 0
        while not stop.is_set():
            sock.sendto(msgpack.packb({"type": "tracker", "seq": seq, "t": time.monotonic() * 1e3, "pos": IN_CONTACT}),
                        (host, int(port)))
            seq += 1
            time.sleep(0.005)


@pytest.fixture
def rig_server(tmp_path, monkeypatch):
    monkeypatch.setenv("VIESTAC_RIG_DIR", str(tmp_path))
    proc, base = start_server("contact-angle", extra=["--rig", "ferrovibe"])
    stop = threading.Event()
    tracker = threading.Thread(target=hold_contact, args=(get_json(base + "/api/health")["tracker_udp"], stop),
                               daemon=True)
    tracker.start()
    try:
        yield base, tmp_path
    finally:
        stop.set()
        tracker.join(2)
        stop_server(proc)


def tilted_since(path: Path, after_us: int) -> bool:
    rows = [r for r in timeline(path) if int(r["t_us"]) >= after_us]
    return bool(rows) and int(rows[-1]["magnitude_pct"]) > 0


def kill_loop_and_measure(base: str, rig_dir: Path) -> tuple[float, int]:
    """SIGKILL the loop while the tilt is held: (ms from the kill to the timeline's flat tilt,
    CLOCK_MONOTONIC µs of the kill)."""
    path = rig_dir / "ferrovibe-timeline.csv"
    wait_for(lambda: tilted_since(path, 0), 10.0, "the tilt never showed")
    pid = get_json(base + "/api/health")["loop"]["pid"]
    time.sleep(0.3)
    killed_us = time.monotonic_ns() // 1000
    os.kill(pid, signal.SIGKILL)
    time.sleep(0.5)  # the emulator flushes its timeline every 0.2 s
    flat = wait_for(lambda: next((int(r["t_us"]) for r in timeline(path)
                                  if int(r["t_us"]) > killed_us and int(r["magnitude_pct"]) == 0), None),
                    3.0, "the tilt stayed on after the loop was killed")
    return (flat - killed_us) / 1000, killed_us


@pytest.mark.slow
def test_a_killed_loop_leaves_the_ferrovibe_flat_within_50_ms(rig_server):
    base, rig_dir = rig_server
    off_ms, killed_us = kill_loop_and_measure(base, rig_dir)
    print(f"\nflat {off_ms:.1f} ms after the loop was killed")
    assert off_ms <= 50
    info = get_json(base + "/api/devices")["feed"]
    assert info["quiet_offs"] >= 1
    # the restarted loop's cues (the tracker still holds the contact) tilt it again
    wait_for(lambda: tilted_since(rig_dir / "ferrovibe-timeline.csv", killed_us), 10.0,
             "the tilt did not come back with the restarted loop")


@pytest.mark.slow
def test_a_restarted_emulator_is_connected_and_identified_within_1_s(rig_server):
    base, rig_dir = rig_server
    devices = get_json(base + "/api/devices")
    os.kill(devices["simulated_rig"]["emulators"]["ferrovibe"]["pid"], signal.SIGKILL)
    wait_for(lambda: get_json(base + "/api/devices")["devices"][0]["status"] == "disconnected", 2.0, "not noticed")
    link, timeline_path = rig_dir / "ferrovibe", rig_dir / "ferrovibe-timeline.csv"
    new = subprocess.Popen(emulator_command("ferrovibe", link, timeline_path, append_timeline=True,
                                            exit_with_parent=False),
                           stdout=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        assert new.stdout.readline()  # its first line comes once the link leads to the new pty
        up = time.monotonic()
        wait_for(lambda: (d := get_json(base + "/api/devices")["devices"][0])["status"] == "connected"
                 and d["identity"] is not None, 3.0, "no reconnect")
        took = time.monotonic() - up
        print(f"\nreconnected {took * 1000:.0f} ms after the new emulator was up")
        assert took <= 1.0
    finally:
        new.terminate()
        new.wait(5)


def test_a_killed_device_host_leaves_the_device_flat_by_its_own_watchdog(tmp_path):
    emulator = Emulator("ferrovibe", link=tmp_path / "ferrovibe")
    emulator.start()
    control, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    feed_end, loop_end = ipc.channel_pair()
    config = DeviceConfig("ferro", profile_by_model("ferrovibe"), PortSpec.parse(emulator.path))
    proc = subprocess.Popen([sys.executable, "-m", "devices.device_host_process", "--control-fd", str(theirs.fileno()),
                             "--cues-fd", str(feed_end.fileno()), "--cue-quiet-ms", "600000"],
                            stdin=subprocess.PIPE, pass_fds=(theirs.fileno(), feed_end.fileno()), cwd=ROOT)
    try:
        proc.stdin.write(pickle.dumps([config]))
        proc.stdin.close()
        theirs.close()
        wait_for(lambda: emulator.core.counters()["frames_ok"] > 3, 10.0, "the host never talked to the device")
        assert ipc.send_record(loop_end, Cues(1, time.monotonic_ns(), [
            {"kind": "tilt", "direction_deg": 315.0, "magnitude_pct": 100.0}]))
        wait_for(lambda: any(e.magnitude == 100 for e in emulator.snapshot_edges()), 3.0, "no tilt")
        time.sleep(0.3)  # idle: only keepalives feed the watchdog now
        killed_us = time.monotonic_ns() // 1000
        proc.kill()
        proc.wait(5)
        trip = wait_for(lambda: next((e for e in emulator.snapshot_edges() if e.cause == "watchdog"), None), 2.0,
                        "the device stayed tilted after its host died")
        last_frame_us = max(t for t, _ in emulator.snapshot_received() if t <= trip.t_us)
        print(f"\nflat {(trip.t_us - killed_us) / 1000:.1f} ms after the host was killed "
              f"({(trip.t_us - last_frame_us) / 1000:.1f} ms after its last frame)")
        assert trip.magnitude == 0 and trip.t_us == last_frame_us + WATCHDOG_MS * 1000
        assert trip.t_us - killed_us <= WATCHDOG_MS * 1000
    finally:
        if proc.poll() is None:
            proc.kill()
        control.close()
        loop_end.close()
        feed_end.close()
        emulator.stop()
