"""`viestac bench audio`: cue → the first sample of the new waveform at the output port, for an
audio tactor under a JACK dummy server, per block size.

For each block size a JACK server runs with that period (48 kHz), an AudioDevice streams to it
through PortAudio (its worker process, as in the device host) and a capture client records the
port. Each measured cue turns a silent channel on (the encoder's continuous vibration at 250 Hz,
`AudioDevice.set_commands`, what the device feed calls); the latency is from just before that call
to the first nonzero sample at the port, whose time is the capture's cycle time (CLOCK_MONOTONIC
when JACK ran the cycle that carried it) plus its offset in the block. Then the channel is turned
off and released before the next cue. Expected: up to one block period (the cue waits for the next
cycle) plus the hand-over (a datagram to the worker, its receiving thread, the slot).
"""

from __future__ import annotations

import time

import numpy as np

from devices.audio.capture import Capture
from devices.audio.config import AudioChannel, AudioConfig
from devices.audio.device import AudioDevice
from devices.audio.jack_server import JackServer, jack_module
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


def measure_block(block: int, cues: int) -> dict:
    server = JackServer(rate=RATE, period=block, outputs=1).start()
    capture = device = None
    try:
        capture = Capture(server.name, 1, seconds=30.0).start()
        config = AudioConfig(output="system", host_api="JACK", jack_server=server.name, sample_rate=RATE, block=block,
                             ramp_ms=1.0, channels=(AudioChannel("coil", 1),))
        device = AudioDevice("bench", config, 250)
        device.start()
        _wait(lambda: device.status == "connected", 60.0, f"the device ({device.last_error})")
        _wait(capture.connected, 30.0, "the capture")
        time.sleep(0.2)
        latencies_ms = []
        quiet_frames = int(0.004 * RATE) + 2 * block  # the release ramp and two blocks
        attempts = 0
        while len(latencies_ms) < cues:
            attempts += 1
            if attempts > 3 * cues:
                raise RuntimeError(f"bench audio: only {len(latencies_ms)} of {attempts} cues started from silence")
            device.set_commands(OFF)
            start = capture.frames
            _wait(lambda start=start: capture.frames > start + quiet_frames, 5.0, "silence")
            tail_frames = capture.read(capture.frames - block, capture.frames)
            if np.any(tail_frames):
                continue  # not released yet (a late worker): this cue would not start from silence
            searched = capture.frames
            t0 = time.monotonic_ns()
            device.set_commands(ON)
            found = []

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
            if t is not None:
                latencies_ms.append((t - t0) / 1e6)
        latencies_ms.sort()
        return {"block": block, "block_ms": round(block / RATE * 1000, 3), "cues": len(latencies_ms),
                "skipped": attempts - len(latencies_ms),
                **tail(latencies_ms, "latency_", "_ms"), "underruns": device.underruns}
    finally:
        if device is not None:
            device.stop()
        if capture is not None:
            capture.stop()
        server.stop()


def run_audio_bench(blocks=(32, 64, 128, 256), cues: int = 1000) -> dict:
    jack = jack_module()
    jack.set_error_function(lambda message: None)
    jack.set_info_function(lambda message: None)
    return {f"block_{b}": measure_block(b, cues) for b in blocks}
