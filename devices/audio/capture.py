"""A JACK capture client: what ViESTac plays, sample for sample, at its output ports.

It registers one input per playback channel of the server (`in_1` … `in_N`) and keeps connecting
each to whatever plays into `system:playback_N` (ViESTac's PortAudio client, also after it
reconnected), so it records what a sound card would get. The process callback copies every block
into a preallocated ring and notes each cycle's first frame with the CLOCK_MONOTONIC time it ran
(`cycles`), so a sample's frame is also a time (the bench: cue → first sample at the port).

`Timeline` turns the recording into the actuator timeline of the simulated rig (one CSV row per
change of a channel's gate, peak or frequency), like the serial emulators' edges.
"""

from __future__ import annotations

import csv
import math
import threading
import time
from pathlib import Path

import numpy as np

from devices.audio.jack_server import jack_module


class Capture:
    def __init__(self, server: str, channels: int = 2, *, seconds: float = 60.0, name: str = "viestac-capture",
                 rate: int = 48_000):
        jack = jack_module()
        self.client = jack.Client(name, servername=server, no_start_server=True)
        self.rate = self.client.samplerate or rate
        self.ports = [self.client.inports.register(f"in_{k + 1}") for k in range(channels)]
        self.size = int(seconds * self.rate)
        self.ring = np.zeros((self.size, channels), np.float32)
        self.frames = 0  # frames recorded (the ring's write position, unwrapped)
        self.first_frame: int | None = None  # JACK frame time of the first recorded frame
        self.cycles = np.zeros((8192, 2), np.int64)  # (recorded frame index, monotonic ns) per cycle
        self.cycle_count = 0
        self.shutdown = False
        self._running = False
        self.client.set_process_callback(self._process)
        self.client.set_shutdown_callback(self._on_shutdown)
        self._thread: threading.Thread | None = None

    def _on_shutdown(self, status, reason) -> None:
        self.shutdown = True

    def _process(self, frames: int) -> None:
        now = time.monotonic_ns()
        if self.first_frame is None:
            self.first_frame = self.client.last_frame_time
        k = self.cycle_count % len(self.cycles)
        self.cycles[k, 0], self.cycles[k, 1] = self.frames, now
        self.cycle_count += 1
        start = self.frames % self.size
        end = start + frames
        for i, port in enumerate(self.ports):
            data = port.get_array()
            if end <= self.size:
                self.ring[start:end, i] = data
            else:
                split = self.size - start
                self.ring[start:, i] = data[:split]
                self.ring[:end - self.size, i] = data[split:]
        self.frames += frames

    def start(self) -> Capture:
        self.client.activate()
        self._running = True
        self._thread = threading.Thread(target=self._follow, name="capture-connect", daemon=True)
        self._thread.start()
        return self

    def _follow(self) -> None:
        """Connect in_k to every port that plays into system:playback_k (JACK forbids connecting
        from its callbacks, so a thread looks every 20 ms)."""
        while self._running and not self.shutdown:
            try:
                for k, port in enumerate(self.ports):
                    sink = f"system:playback_{k + 1}"
                    mine = {p.name for p in self.client.get_all_connections(port)}
                    for source in self.client.get_all_connections(sink):
                        if source.name not in mine:
                            self.client.connect(source, port)
            except Exception:  # noqa: BLE001 - ports come and go while a client reconnects
                pass
            time.sleep(0.02)

    def connected(self) -> bool:
        """Every input follows something (ViESTac's stream is up)."""
        try:
            return all(self.client.get_all_connections(p) for p in self.ports)
        except Exception:  # noqa: BLE001
            return False

    def read(self, start: int, end: int | None = None) -> np.ndarray:
        """Recorded frames [start, end) (indices since the capture began), shape (n, channels)."""
        end = self.frames if end is None else end
        if start < self.frames - self.size:
            raise ValueError("those frames are no longer in the ring")
        idx = np.arange(start, end) % self.size
        return self.ring[idx]

    def time_ns(self, frame: int) -> int | None:
        """CLOCK_MONOTONIC ns at which the cycle holding `frame` ran, plus the frame's offset in it."""
        n = min(self.cycle_count, len(self.cycles))
        rows = self.cycles[[(self.cycle_count - n + i) % len(self.cycles) for i in range(n)]]
        i = int(np.searchsorted(rows[:, 0], frame, side="right")) - 1
        if i < 0:
            return None
        first, t = rows[i]
        return int(t + (frame - first) * 1e9 / self.rate)

    def stop(self) -> None:
        self._running = False
        if self._thread is not None:
            self._thread.join(timeout=1)
        try:
            self.client.deactivate()
            self.client.close()
        except Exception:  # noqa: BLE001 - the server may be gone already
            pass


class Timeline:
    """The recording as edges: one row per change of a channel's gate (anything playing), its
    peak (by more than `peak_step` of full scale) or its frequency (by more than `hz_step`), over
    windows of `window` frames. Columns: t_us (CLOCK_MONOTONIC), channel, gate, peak, frequency_hz."""

    COLUMNS = ("t_us", "channel", "gate", "peak", "frequency_hz")

    def __init__(self, capture: Capture, path: str | Path, *, names: tuple[str, ...] = (), window: int = 480,
                 peak_step: float = 0.02, hz_step: float = 2.0, append: bool = False):
        self.capture = capture
        self.names = names or tuple(f"out_{k + 1}" for k in range(len(capture.ports)))
        self.window, self.peak_step, self.hz_step = window, peak_step, hz_step
        self.path = Path(path)
        new = not append or not self.path.exists()
        self.file = self.path.open("a" if append else "w", newline="")
        self.writer = csv.writer(self.file)
        if new:
            self.writer.writerow(self.COLUMNS)
            self.file.flush()
        self.position = 0
        self.last: list[tuple[int, float, float]] = [(0, 0.0, 0.0)] * len(capture.ports)
        self.rows = 0

    def poll(self) -> int:
        """Write the rows of every whole window recorded since the last poll; returns how many."""
        written = 0
        while self.capture.frames - self.position >= self.window:
            block = self.capture.read(self.position, self.position + self.window)
            t_ns = self.capture.time_ns(self.position)
            for k in range(block.shape[1]):
                x = block[:, k]
                peak = float(np.max(np.abs(x)))
                gate = int(peak > 1e-4)
                hz = _zero_crossing_hz(x, self.capture.rate) if gate else 0.0
                g0, p0, f0 = self.last[k]
                if gate != g0 or abs(peak - p0) > self.peak_step or abs(hz - f0) > self.hz_step:
                    self.writer.writerow([(t_ns or 0) // 1000, self.names[k], gate, f"{peak:.4f}", f"{hz:.1f}"])
                    self.last[k] = (gate, peak, hz)
                    written += 1
            self.position += self.window
        if written:
            self.file.flush()
            self.rows += written
        return written

    def close(self) -> None:
        self.poll()
        self.file.close()


def _zero_crossing_hz(x: np.ndarray, rate: int) -> float:
    """A window's frequency from the spacing of its rising zero crossings (0 if fewer than two)."""
    rising = np.nonzero((x[:-1] < 0) & (x[1:] >= 0))[0]
    if len(rising) < 2:
        return 0.0
    # sub-sample crossing positions by linear interpolation
    a, b = x[rising], x[rising + 1]
    pos = rising + a / (a - b)
    cycles = len(pos) - 1
    span = pos[-1] - pos[0]
    return float(cycles * rate / span) if span > 0 and math.isfinite(span) else 0.0
