"""`viestac bench audio`: cue → the first sample of the new waveform at the output port, for an
audio tactor under a JACK dummy server, per block size, against the JACK graph's own latency
measured in the same run.

For each block size a JACK server runs with that period (48 kHz) and a capture client records its
playback port. Two sources are measured in turn, each turning a silent port on `cues` times:

- `graph` (the baseline): a JACK client in this process whose process callback writes a constant
  level once a flag is set. Latency = from setting the flag to the first nonzero sample at the
  port: the wait for the next cycle (block quantisation) and the lateness of that cycle (how JACK
  and the machine schedule the graph), nothing else.
- `cue`: an AudioDevice streaming through PortAudio from its worker process, as in the device
  host. Each cue is the encoder's continuous vibration at 250 Hz handed to
  `AudioDevice.set_commands` (what the device feed calls); the latency is from just before that
  call to the first nonzero sample at the port. On top of the graph's: the hand-over (a datagram
  to the worker, its receiving thread, the single slot the audio callback reads) and PortAudio.

A sample's time is the capture's cycle time (CLOCK_MONOTONIC when JACK ran the capture in the
cycle that carried it) plus its offset in the block. For each cue the bench also notes how many
cycles began between the cue and the cycle that carried it (`missed_cycles`: 0 when the cue made
the first cycle after it; 1 or more when the hand-over was slower than the wait for that cycle),
so a tail can be told apart: late cycles (the graph's tail too) or a late hand-over (missed
cycles). Then the source is turned off and released before the next cue.

jackd runs with real-time priority when this process may use SCHED_FIFO (`realtime`), as the
simulated rig's audio emulator does; `realtime=False` measures without it.
"""

from __future__ import annotations

import os
import time

import numpy as np

from devices.audio.capture import Capture
from devices.audio.config import AudioChannel, AudioConfig
from devices.audio.device import AudioDevice
from devices.audio.jack_server import JackServer, jack_module, realtime_allowed
from devices.messages import ALL_CHANNELS, SetPattern
from server.bench.quantiles import tail

RATE = 48_000
ON = (SetPattern.continuous(ALL_CHANNELS, 50, 250),)
OFF = (SetPattern.off(ALL_CHANNELS),)


def _wait(predicate, timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            raise RuntimeError(f"bench audio: timed out waiting for {what}")
        time.sleep(0.0005)


class _GraphSource:
    """The baseline: a JACK client of this process that plays `level` into the playback port."""

    def __init__(self, server: str):
        jack = jack_module()
        self.client = jack.Client("viestac-bench-source", servername=server, no_start_server=True)
        self.port = self.client.outports.register("out_1")
        self.level = 0.0
        self.client.set_process_callback(self._process)

    def _process(self, frames: int) -> None:
        self.port.get_array().fill(self.level)

    def start(self) -> _GraphSource:
        self.client.activate()
        self.client.connect(self.port, "system:playback_1")
        return self

    def on(self) -> None:
        self.level = 0.5

    def off(self) -> None:
        self.level = 0.0

    def close(self) -> None:
        self.client.deactivate()
        self.client.close()


class _DeviceSource:
    """An AudioDevice, as in the device host (its worker process, PortAudio's JACK host API)."""

    def __init__(self, server: str, block: int):
        config = AudioConfig(output="system", host_api="JACK", jack_server=server, sample_rate=RATE, block=block,
                             ramp_ms=1.0, channels=(AudioChannel("coil", 1),))
        self.device = AudioDevice("bench", config, 250)

    def start(self) -> _DeviceSource:
        self.device.start()
        _wait(lambda: self.device.status == "connected", 60.0, f"the device ({self.device.last_error})")
        return self

    def on(self) -> None:
        self.device.set_commands(ON)

    def off(self) -> None:
        self.device.set_commands(OFF)

    def close(self) -> None:
        self.device.stop()


def _cycle_index(capture: Capture, frame: int) -> int:
    """The capture's cycle count at the cycle that recorded `frame` (frames → cycles, newest ring)."""
    n = min(capture.cycle_count, len(capture.cycles))
    base = capture.cycle_count - n
    rows = capture.cycles[[(base + i) % len(capture.cycles) for i in range(n)]]
    return base + int(np.searchsorted(rows[:, 0], frame, side="right")) - 1


def _measure(source, capture: Capture, block: int, cues: int) -> dict:
    latencies_ms: list[float] = []
    missed: list[int] = []
    quiet_frames = int(0.003 * RATE) + 2 * block  # the release ramp and two blocks
    attempts = 0
    while len(latencies_ms) < cues:
        attempts += 1
        if attempts > 3 * cues:
            raise RuntimeError(f"bench audio: only {len(latencies_ms)} of {attempts} cues started from silence")
        source.off()
        start = capture.frames
        _wait(lambda start=start: capture.frames > start + quiet_frames, 5.0, "silence")
        if np.any(capture.read(capture.frames - block, capture.frames)):
            continue  # not released yet (a late worker): this cue would not start from silence
        searched, cycles_before = capture.frames, capture.cycle_count
        t0 = time.monotonic_ns()
        source.on()
        found: list[int] = []

        def onset(searched=searched, found=found) -> bool:
            end = capture.frames
            if end > searched:
                nonzero = np.flatnonzero(capture.read(searched, end)[:, 0])
                if len(nonzero):
                    found.append(searched + int(nonzero[0]))
                    return True
            return False

        _wait(onset, 5.0, "the onset")
        t = capture.time_ns(found[0])
        if t is None:
            continue
        latencies_ms.append((t - t0) / 1e6)
        # cycles that began after the cue and before the one that carried it (the cycle running
        # when the cue came, counted in cycles_before, may still have been before the capture)
        missed.append(max(0, _cycle_index(capture, found[0]) - cycles_before))
    order = np.argsort(latencies_ms)
    latencies = [latencies_ms[i] for i in order]
    missed_sorted = [missed[i] for i in order]
    worst = missed_sorted[int(0.99 * len(missed_sorted)):]  # the cues at and above p99
    return {"cues": len(latencies), "skipped": attempts - len(latencies), **tail(latencies, "latency_", "_ms"),
            "missed_cycle_share": round(float(np.mean([m > 0 for m in missed])), 4),
            "tail_missed_cycle_share": round(float(np.mean([m > 0 for m in worst])), 4) if worst else None}


def measure_block(block: int, cues: int, *, realtime: bool) -> dict:
    server = JackServer(rate=RATE, period=block, outputs=1, realtime=realtime).start()
    capture = source = None
    xruns = [0]
    try:
        capture = Capture(server.name, 1, seconds=30.0)
        capture.client.set_xrun_callback(lambda delay: xruns.__setitem__(0, xruns[0] + 1))
        capture.start()
        out = {"block": block, "block_ms": round(block / RATE * 1000, 3), "jack_realtime": realtime}
        for name, make in (("graph", lambda: _GraphSource(server.name)), ("cue", lambda: _DeviceSource(server.name, block))):
            source = make().start()
            _wait(capture.connected, 30.0, "the capture")
            time.sleep(0.2)
            before = xruns[0]
            result = _measure(source, capture, block, cues)
            result["xruns"] = xruns[0] - before
            if isinstance(source, _DeviceSource):
                result["underruns"] = source.device.underruns
            source.close()
            source = None
            _wait(lambda: not capture.connected(), 10.0, "the source to leave")
            out[name] = result
        out["cue_minus_graph_p50_ms"] = round(out["cue"]["latency_p50_ms"] - out["graph"]["latency_p50_ms"], 3)
        return out
    finally:
        if source is not None:
            source.close()
        if capture is not None:
            capture.stop()
        server.stop()


def run_audio_bench(blocks=(32, 64, 128, 256), cues: int = 1000, realtime: bool | None = None) -> dict:
    """`realtime`: jackd with real-time priority (None: when this process may use SCHED_FIFO)."""
    jack = jack_module()
    jack.set_error_function(lambda message: None)
    jack.set_info_function(lambda message: None)
    realtime = realtime_allowed() if realtime is None else realtime
    load = os.getloadavg()
    result = {f"block_{b}": measure_block(b, cues, realtime=realtime) for b in blocks}
    result["load_average"] = [round(v, 2) for v in load] + [round(v, 2) for v in os.getloadavg()]  # before, after
    result["cpus"] = os.cpu_count()
    return result
