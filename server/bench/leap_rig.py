"""A whole tracked rig on one machine, for end-to-end tests and `viestac bench tracking`:
Leap Motion emulator (its own process) → server (`--tracker leap:URL`, tracker host, loop) →
FerroVibe emulator on a pty (in this process, stamping every actuator edge on CLOCK_MONOTONIC).

Paths are written in the scene frame and turned into Leap millimetres with the Leap's default
calibration (server/tracking/calibration.py), which the server applies back.
"""

from __future__ import annotations

import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from devices.emulator import Emulator
from server.launcher import get_json, start_server, stop_server
from server.tracking import replay
from server.tracking.calibration import leap_default


def leap_csv(times, scene_rows) -> str:
    """Scene-frame rows (point → xyz) as the Leap would report them (mm, device frame)."""
    cal = leap_default()
    return replay.write_csv(times, [{n: cal.invert(p) for n, p in row.items()} for row in scene_rows])


class LeapRig:
    def __init__(self, scene_times, scene_rows, *, scenario: str = "contact-angle", extra: list[str] | None = None,
                 devices: dict[str, str] | None = None, rate_hz: float = 110.0, realtime: bool = False):
        self.dir = Path(tempfile.mkdtemp(prefix="viestac-leaprig-"))
        self.frames = self.dir / "frames.csv"
        self.frames.write_text(leap_csv(scene_times, scene_rows))
        self.timeline = self.dir / "leap_timeline.txt"
        self.rate_hz = rate_hz
        self.realtime = realtime  # the emulators as measuring instruments (SCHED_FIFO), for the bench
        self.devices = devices or {"ferrovibe": "ferrovibe"}  # name → model
        self.emulators = {name: Emulator(model, link=self.dir / name, realtime=realtime)
                          for name, model in self.devices.items()}
        self.scenario, self.extra = scenario, list(extra or [])
        self.leap: subprocess.Popen | None = None
        self.leap_port = 0
        self.server = None
        self.base = ""

    def start_leap(self) -> None:
        self.leap = subprocess.Popen([sys.executable, "-m", "server.cli", "emulate", "leap", "--frames", str(self.frames),
                                      "--port", str(self.leap_port), "--rate", str(self.rate_hz),
                                      "--timeline", str(self.timeline), *(["--realtime"] if self.realtime else [])],
                                     stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        line = self.leap.stdout.readline()
        match = re.search(r"ws://127\.0\.0\.1:(\d+)/", line)
        if not match:
            raise RuntimeError(f"the Leap emulator did not start: {line!r}")
        self.leap_port = int(match.group(1))

    def stop_leap(self) -> int:
        """Kill the Leap emulator (as a crashed service); the CLOCK_MONOTONIC ns of its last frame."""
        self.leap.send_signal(signal.SIGKILL)
        self.leap.wait()
        return self.last_frame_ns()

    def last_frame_ns(self) -> int:
        lines = self.timeline.read_text().split("\n") if self.timeline.exists() else []
        lines = [ln for ln in lines if ln.strip()]
        return int(lines[-1].split()[1]) if lines else 0

    def frames_sent(self) -> list[tuple[int, int]]:
        return [tuple(map(int, ln.split())) for ln in self.timeline.read_text().splitlines() if ln.strip()]

    def __enter__(self) -> "LeapRig":
        for emulator in self.emulators.values():
            emulator.start()
        self.start_leap()
        args = ["--no-rig", "--tracker", f"leap:ws://127.0.0.1:{self.leap_port}/v6.json", *self.extra]
        for name, emulator in self.emulators.items():
            args += ["--device", f"{name}={self.devices[name]}@{emulator.path}"]
        self.server, self.base = start_server(self.scenario, extra=args)
        deadline = time.monotonic() + 15
        while True:
            devices = get_json(self.base + "/api/devices")["devices"]
            if devices and all(d["status"] == "connected" for d in devices):
                break
            if time.monotonic() > deadline:
                raise RuntimeError(f"devices did not connect: {devices}")
            time.sleep(0.05)
        return self

    def __exit__(self, *exc) -> None:
        if self.leap is not None and self.leap.poll() is None:
            self.leap.kill()
            self.leap.wait()
        if self.server is not None:
            stop_server(self.server)
        for emulator in self.emulators.values():
            emulator.stop()
        shutil.rmtree(self.dir, ignore_errors=True)

    def source(self, name: str = "leap") -> dict:
        return next(s for s in get_json(self.base + "/api/trackers?limit=1")["sources"] if s["name"] == name)

    def wait_source(self, status: set[str], timeout_s: float = 10.0) -> dict:
        deadline = time.monotonic() + timeout_s
        while True:
            src = self.source()
            if src["status"] in status:
                return src
            if time.monotonic() > deadline:
                raise AssertionError(f"tracker source never became {status}: {src}")
            time.sleep(0.02)
