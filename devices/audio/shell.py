"""AudioOutput: one PortAudio output stream (sounddevice) around the synthesis core
(devices/audio/synth.py). It runs in an audio worker process of its own (devices/audio/worker.py),
which the device host starts for each audio device (devices/audio/device.py); never in the loop.

Cue hand-over is lock-free: `publish` puts `(generation, stimuli)` in one slot with a single
reference assignment (atomic in CPython); the callback compares the generation with the one it
last took and, when newer, hands the synth the stimuli that changed before rendering that block
(`publish` keeps the very object of a channel whose stimulus is equal to the last one, so the
callback compares by identity: a timed stimulus handed over again is not started again). The
callback never allocates arrays, takes a lock or logs: it renders straight into PortAudio's buffer,
counts underruns and blocks in plain integers and notes, in preallocated arrays, the sample at
which each generation started.

Why a process of its own: when the audio server dies, PortAudio's JACK host API leaves the stream
neither running nor stopped, and stopping, closing it or terminating PortAudio then waits for
ever (measured here with jackd2 1.9 and PortAudio 19.6). Only a new process sees the server again,
so the worker reports the death and exits, and the device host starts another.
"""

from __future__ import annotations

import ctypes
import os

import numpy as np

from devices.audio.config import AudioConfig, AudioConfigError
from devices.audio.synth import OFF, Stimulus, Synth

CLIENT_NAME = b"viestac"  # the JACK client's name (its ports: viestac:out_0 …)
TOOK = 4096  # the ring of (generation, first sample) the callback keeps


def portaudio(jack_server: str | None = None):
    """sounddevice, with PortAudio initialised to see `jack_server` (its import initialises
    PortAudio and its JACK host API exists only when a server answered then). Call once per
    process, before any stream."""
    if jack_server:
        os.environ["JACK_DEFAULT_SERVER"] = jack_server
    os.environ.setdefault("JACK_NO_START_SERVER", "1")  # find a server, never start one
    try:
        import sounddevice as sd
    except (ImportError, OSError) as exc:
        raise AudioConfigError(f"sounddevice/PortAudio is not available ({exc}): pip install -e '.[audio]' "
                               "and the PortAudio library (Debian: libportaudio2)") from None
    while sd._initialized:
        sd._terminate()
    try:  # name the JACK client (the symbol exists when PortAudio was built with JACK)
        ctypes.CDLL(sd._libname).PaJack_SetClientName(CLIENT_NAME)
    except (OSError, AttributeError):
        pass
    sd._initialize()
    return sd


class AudioOutput:
    def __init__(self, config: AudioConfig):
        self.config = config
        self.synth = Synth(config.sample_rate, config.outputs, max(config.block, 8192), ramp_s=config.ramp_ms / 1000)
        self._slot: tuple[int, tuple[Stimulus, ...]] = (0, (OFF,) * config.outputs)
        self._taken = 0
        self._given = self._slot[1]  # the stimuli the callback last handed to the synth
        self.blocks = 0
        self.underruns = 0
        self.took_generation = np.zeros(TOOK, np.int64)
        self.took_sample = np.zeros(TOOK, np.int64)
        self.took_count = 0
        self.stream = None
        self.device_name: str | None = None

    def open(self, sd) -> None:
        """Find the configured output and start streaming; AudioConfigError names what is wrong."""
        index = self.config.check_output(sd.query_devices(), sd.query_hostapis())
        try:
            sd.check_output_settings(device=index, channels=self.config.outputs, dtype="float32",
                                     samplerate=self.config.sample_rate)
        except sd.PortAudioError as exc:
            raise AudioConfigError(f"unsupported sample rate {self.config.sample_rate} Hz for "
                                   f"{self.config.output!r}: {exc}") from None
        self.stream = sd.OutputStream(samplerate=self.config.sample_rate, blocksize=self.config.block, device=index,
                                      channels=self.config.outputs, dtype="float32", callback=self._callback,
                                      latency="low")
        self.device_name = sd.query_devices(index)["name"]
        self.stream.start()

    @property
    def alive(self) -> bool:
        try:
            return self.stream is not None and bool(self.stream.active)
        except Exception:  # noqa: BLE001 - a stream of a dead server may fail any call
            return False

    def publish(self, generation: int, stimuli: tuple[Stimulus, ...]) -> None:
        last = self._slot[1]
        if len(last) == len(stimuli):
            stimuli = tuple(old if old == new else new for old, new in zip(last, stimuli))
        self._slot = (generation, stimuli)  # one reference: the callback sees all of it or none

    @property
    def taken(self) -> int:
        return self._taken

    @property
    def published(self) -> int:
        return self._slot[0]

    def took_since(self, count: int) -> tuple[int, list[tuple[int, int]]]:
        """(new count, the (generation, sample) pairs noted since `count`)."""
        end = self.took_count
        start = max(count, end - TOOK)
        return end, [(int(self.took_generation[i % TOOK]), int(self.took_sample[i % TOOK])) for i in range(start, end)]

    def _callback(self, outdata, frames, time_info, status) -> None:
        if status.output_underflow:
            self.underruns += 1
        generation, stimuli = self._slot
        synth = self.synth
        if generation != self._taken:
            self._taken = generation
            given = self._given
            for i in range(len(stimuli)):
                if stimuli[i] is not given[i]:
                    synth.set(i, stimuli[i])
            self._given = stimuli
            k = self.took_count % TOOK
            self.took_generation[k] = generation
            self.took_sample[k] = synth.sample
            self.took_count += 1
        synth.render(outdata)
        self.blocks += 1
