"""The simulated rig: device emulators in their own processes, reached through the real pyserial
path, so `viestac serve` without hardware exercises exactly the byte path a lab's devices use.

Each emulator is `python -m devices.emulator MODEL --link DIR/MODEL --timeline DIR/MODEL-timeline.csv`;
the server opens DIR/MODEL like any serial port. The timelines record every actuator change.

A dead emulator is not restarted by the rig: a device that died must show as missing (status
`disconnected`, `alive: false` in `info()`), as a real one would. Whoever killed it (the fault
bench, a test, a person) starts it again with `restart(model)` or `emulator_command(...)`; the
host's reader reopens the same link path within its reopen interval (0.5 s) and handshakes
(docs/device-protocol.md §4.5). The timeline file is appended to, not truncated, so one CSV
covers the emulator before and after the restart.

The links and timelines live in the directory given, kept; without one, in a temporary directory
that `stop()` removes.
"""

from __future__ import annotations

import logging
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from dataclasses import replace

from devices.audio.config import AudioChannel, AudioConfig
from devices.audio.jack_server import unique_name
from devices.firmware_binding import ensure_library
from devices.manager import DeviceConfig
from devices.ports import PortSpec
from devices.profiles import profile_by_model

AUDIO_MODEL = "audio"  # the rig's voice-coil tactor: a JACK dummy server and a capture (devices/audio/emulator.py)
BROWSER_MODEL = "browser"  # the participant page's actuators: no emulator, the page is the device (devices/browser.py)

log = logging.getLogger("viestac.devices")


class SimulatedRig:
    def __init__(self, models: tuple[str, ...] = ("fingertac", "ferrovibe"), directory: str | Path | None = None):
        for model in models:
            profile_by_model(model)  # fail early on a typo
        self.models = models
        self.directory = Path(directory) if directory else None
        self._temporary = False  # start() made the directory: stop() removes it (a given one is kept)
        self.procs: dict[str, subprocess.Popen] = {}
        self.jack_server = unique_name("viestac-rig")  # the audio emulator's, kept across its restarts

    def link(self, model: str) -> Path:
        return self.directory / model

    def timeline(self, model: str) -> Path:
        return self.directory / f"{model}-timeline.csv"

    def start(self, timeout_s: float = 10.0) -> list[DeviceConfig]:
        if self.directory is None:
            self.directory = Path(tempfile.mkdtemp(prefix="viestac-rig-"))
            self._temporary = True
        self.directory.mkdir(parents=True, exist_ok=True)
        ensure_library()  # build the firmware core once, before several emulators race to do it
        for model in self.models:
            if model == BROWSER_MODEL:  # the page connects over /ws: nothing to start
                continue
            self.link(model).unlink(missing_ok=True)
            self.procs[model] = self._spawn(model)
        if AUDIO_MODEL in self.models:  # a JACK server takes seconds to answer on a busy machine
            timeout_s = max(timeout_s, 60.0)
        deadline = time.monotonic() + timeout_s
        for model, proc in self.procs.items():
            while not self.link(model).exists():
                if proc.poll() is not None or time.monotonic() > deadline:
                    self.stop()
                    raise RuntimeError(f"the {model} emulator did not start (exit code {proc.poll()})")
                time.sleep(0.01)
        log.info("simulated rig: %s in %s", ", ".join(self.models), self.directory)
        return [self._config(model) for model in self.models]

    def _config(self, model: str) -> DeviceConfig:
        if model == BROWSER_MODEL:
            return DeviceConfig(name=model, profile=profile_by_model(model), port=None)
        if model != AUDIO_MODEL:
            return DeviceConfig(name=model, profile=profile_by_model(model), port=PortSpec.parse(str(self.link(model))))
        audio = AudioConfig(output="system", host_api="JACK", jack_server=self.jack_server,
                            channels=(AudioChannel("coil", 1),))
        return DeviceConfig(name=model, profile=replace(profile_by_model(model), channels=audio.actuators), port=None,
                            audio=audio)

    def _spawn(self, model: str, *, append: bool = False) -> subprocess.Popen:
        return subprocess.Popen(
            emulator_command(model, self.link(model), self.timeline(model), append_timeline=append,
                             jack_server=self.jack_server),
            stdout=subprocess.DEVNULL, cwd=Path(__file__).resolve().parents[1],
            start_new_session=True)  # a terminal's Ctrl-C reaches the server, which stops us in order

    def restart(self, model: str, timeout_s: float = 10.0) -> subprocess.Popen:
        """Start `model`'s emulator again at the same link (after it died or was killed); returns
        once the link points at the new pty. A running one is stopped first (a power cycle)."""
        if model not in self.models or model == BROWSER_MODEL or self.directory is None:
            raise ValueError(f"{model!r} is not an emulator of this rig ({', '.join(self.models)})")
        old = self.procs.get(model)
        if old is not None and old.poll() is None:
            old.terminate()
            old.wait(timeout=3)
        before = _link_id(self.link(model))
        proc = self.procs[model] = self._spawn(model, append=True)
        deadline = time.monotonic() + timeout_s
        while _link_id(self.link(model)) in (None, before):  # the new emulator replaced the link
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"the {model} emulator did not restart (exit code {proc.poll()})")
            time.sleep(0.005)
        log.info("simulated rig: %s emulator restarted (pid %d)", model, proc.pid)
        return proc

    def stop(self) -> None:
        for proc in self.procs.values():
            if proc.poll() is None:
                proc.terminate()
        for proc in self.procs.values():
            try:
                proc.wait(timeout=3)
            except subprocess.TimeoutExpired:
                proc.kill()
        self.procs.clear()
        if self._temporary:  # a server per run must not leave a directory per run behind
            shutil.rmtree(self.directory, ignore_errors=True)
            self.directory, self._temporary = None, False

    def info(self) -> dict:
        return {"directory": str(self.directory), "emulators": {
            model: {"pid": proc.pid, "alive": proc.poll() is None, "link": str(self.link(model)),
                    "timeline": str(self.timeline(model)),
                    **({"jack_server": self.jack_server} if model == AUDIO_MODEL else {})}
            for model, proc in self.procs.items()}}


def emulator_command(model: str, link: Path, timeline: Path, *, append_timeline: bool = False,
                     exit_with_parent: bool = True, jack_server: str | None = None) -> list[str]:
    """The command line of one rig emulator (run with the repository root as working directory).
    A restart appends to the timeline, so one file covers the emulator before and after it. The
    audio emulator's link is a file with its JACK server's name (`jack_server`, kept across
    restarts so the device finds it again)."""
    if model == AUDIO_MODEL:
        return [sys.executable, "-m", "devices.audio.emulator", "--link", str(link), "--timeline", str(timeline),
                "--realtime", *(["--server", jack_server] if jack_server else []),
                *(["--append-timeline"] if append_timeline else []), *(["--exit-with-parent"] if exit_with_parent else [])]
    # --realtime: an emulator stamps a frame when it reads it; starved by a loaded machine for more
    # than the watchdog's 45 ms it trips the watchdog although the host wrote on time (thousands of
    # trips and "write failed: Write timeout" in a 33-minute run beside a CPU hog): a real device has
    # a CPU of its own, so the rig's emulators run at SCHED_FIFO 20 when the server may.
    return [sys.executable, "-m", "devices.emulator", model, "--link", str(link), "--timeline", str(timeline),
            "--realtime", *(["--append-timeline"] if append_timeline else []), *(["--exit-with-parent"] if exit_with_parent else [])]


def _link_id(link: Path) -> tuple[int, int] | None:
    """Which symlink is at `link` now (inode, mtime), None if none: the pty number may repeat."""
    try:
        st = os.lstat(link)
    except FileNotFoundError:
        return None
    return st.st_ino, st.st_mtime_ns


def default_rig_dir() -> Path | None:
    """VIESTAC_RIG_DIR pins the rig's directory (links and timelines); else a fresh temp dir."""
    value = os.environ.get("VIESTAC_RIG_DIR")
    return Path(value) if value else None
