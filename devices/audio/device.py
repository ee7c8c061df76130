"""AudioDevice: an audio device of the rig, as the device manager sees it (like a SerialDevice:
`start`, `stop`, `set_commands`, `status`, `snapshot`), in the device host process.

Its stream runs in an audio worker process (devices/audio/worker.py): `set_commands` turns the
encoder's commands into each output channel's `Stimulus` (devices/audio/mapping.py) and sends them
in one datagram, without waiting for anything. A timed stimulus (a cue with `duration_ms`) is
numbered with an onset of its own when its cue appears; the same cue sent again (another cue of
the set changed) keeps that onset and goes on, and the off that follows it (no cue) is not sent
at all: the stimulus ends on the audio clock after exactly its samples, however late or early the
off arrives (contracts C6). A Stop cue cuts it; a new cue starts a new onset.

A supervisor thread starts the worker, reads its status and counters, and starts another when it
exits: at once after the stream died (the audio server went away; `disconnected` meanwhile, so
health says `device_missing` when the scenario needs the device), and every `reopen_interval_s`
(doubling up to 4 s) while the output is absent. A configuration that cannot work is `refused`
with the worker's message, for good; the rest of the rig runs.

A worker's records are read to the end even when the socket reports a reset: a worker that exits
(a refusal, a death) with stimuli of ours still unread in its socket makes Linux report
ECONNRESET on our end *before* the records it sent last, and only once; stopping there lost its
refusal (the device stayed `connecting` for ever). A worker that says nothing within
`start_timeout_s` (PortAudio waiting on an audio server that does not answer) is killed and
counted as an output that is not there: the device says so and tries again.
"""

from __future__ import annotations

import logging
import pickle
import socket
import subprocess
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from pathlib import Path

from devices.audio.config import AudioConfig, AudioConfigError
from devices.audio.mapping import is_cut, stimuli_for
from devices.audio.synth import OFF, Stimulus
from devices.audio.worker import EXIT_ABSENT, EXIT_REFUSED, EXIT_STOPPED, is_permanent
from devices.protocol import StatusChanged
from server import ipc
from server.ipc.records import FROM_AUDIO_WORKER, AudioCounters, AudioStatus, AudioStimuli, Record, Stop

log = logging.getLogger("viestac.devices")

CONNECTED, CONNECTING, DISCONNECTED, REFUSED = "connected", "connecting", "disconnected", "refused"
_ROOT = Path(__file__).resolve().parents[2]
UNDERRUN_REPORT_S = 1.0  # underruns are announced at most this often (health shows them as a note)
START_TIMEOUT_S = 30.0   # a worker's first report (PortAudio's start takes ~1 s, several s on a busy machine)


@dataclass(frozen=True)
class UnderrunsCounted:
    """The device's underrun count rose (announced at most every UNDERRUN_REPORT_S)."""
    total: int


class AudioDevice:
    def __init__(self, name: str, config: AudioConfig, carrier_hz: float, *, reopen_interval_s: float = 0.5,
                 start_timeout_s: float = START_TIMEOUT_S, on_event: Callable[[str, object], None] | None = None):
        self.name = name
        self.start_timeout_s = start_timeout_s
        self.config = config
        self.carrier_hz = carrier_hz
        self.reopen_interval_s = reopen_interval_s
        self.on_event = on_event
        self._index = {c.actuator: c.channel - 1 for c in config.channels}
        self.stimuli: tuple[Stimulus, ...] = (OFF,) * config.outputs  # as sent to the worker
        self._cued: list[Stimulus] = [OFF] * config.outputs  # as the cues last asked (no onset numbers)
        self._onsets = 0
        self.generation = 0
        self.submitted: deque[tuple[int, int]] = deque(maxlen=4096)  # (generation, monotonic ns when sent)
        self.took: deque[tuple[int, int]] = deque(maxlen=4096)       # (generation, first sample) from the worker
        self.blocks = 0
        self.underruns = 0       # summed over the workers
        self._worker_underruns = 0
        self.next_sample = 0     # the worker's sample clock, as last reported
        self._underruns_announced = (0, 0.0)  # (count, monotonic s) last announced
        self.status = CONNECTING
        self.last_error = ""
        self.warning: str | None = None
        self.path: str | None = None
        self.connects = 0
        self.disconnects = 0
        self.workers = 0
        self.events: deque[dict] = deque(maxlen=200)
        self._sock: socket.socket | None = None
        self._proc: subprocess.Popen | None = None
        self._send_lock = threading.Lock()  # the feed thread and the supervisor both send
        self._running = False
        self._wake = threading.Event()
        self._thread: threading.Thread | None = None

    # ---- the manager's interface (any thread) -----------------------------------------------
    def start(self) -> None:
        self._running = True
        self._thread = threading.Thread(target=self._supervise, name=f"{self.name}-audio", daemon=True)
        self._thread.start()

    def stop(self, drain_s: float = 0.3) -> None:
        """Silence, released over the ramp (not cut), then the worker stops."""
        generation = self._publish((OFF,) * self.config.outputs)
        deadline = time.monotonic() + drain_s
        while self.status == CONNECTED and not any(g >= generation for g, _ in list(self.took)[-4:]) \
                and time.monotonic() < deadline:
            time.sleep(0.005)
        if self.status == CONNECTED:
            time.sleep(min(self.config.ramp_ms / 1000 + 2 * self.config.block / self.config.sample_rate,
                           max(0.0, deadline - time.monotonic())))
        self._running = False
        self._wake.set()
        self._send(Stop())
        proc = self._proc
        if proc is not None:
            try:
                proc.wait(timeout=2)
            except subprocess.TimeoutExpired:
                proc.kill()
        if self._thread is not None:
            self._thread.join(timeout=3)
        self._set_status(DISCONNECTED, "stopped")

    def set_commands(self, commands: Iterable[object], *, write_now: bool = False) -> None:
        """The encoder's newest commands (devices/encoder.py) → every actuator's stimulus."""
        commands = tuple(commands)
        by_channel = stimuli_for(commands, self.config, self.carrier_hz)
        cut = is_cut(commands)
        with self._send_lock:
            stimuli = list(self.stimuli)
            for c, stim in zip(self.config.channels, by_channel):
                k = c.channel - 1
                asked, self._cued[k] = self._cued[k], stim
                if stim == asked and not cut:
                    continue  # the same cue again: a timed stimulus goes on, its onset unchanged
                if stim.silent and asked.duration is not None and not cut:
                    continue  # the off after a timed stimulus: it ends on the audio clock, not here
                if stim.duration is not None:
                    self._onsets += 1
                    stim = replace(stim, onset=self._onsets)
                stimuli[k] = stim
            changed = tuple(stimuli) != self.stimuli
        if changed or cut:
            self._publish(tuple(stimuli))

    def play(self, actuator: str, stimulus: Stimulus) -> int:
        """One actuator's stimulus, given directly (e.g. a 2IFC interval with `start`, a sample of
        the worker's clock, and `duration`); returns its generation."""
        stimuli = list(self.stimuli)
        stimuli[self._index[actuator]] = stimulus
        return self._publish(tuple(stimuli))

    def _publish(self, stimuli: tuple[Stimulus, ...]) -> int:
        with self._send_lock:
            self.generation += 1
            generation = self.generation
            self.stimuli = stimuli
            self.submitted.append((generation, time.monotonic_ns()))
            self._send_locked(AudioStimuli(generation, [s.to_wire() for s in stimuli]))
        return generation

    def _send(self, record: Record) -> None:
        with self._send_lock:
            self._send_locked(record)

    def _send_locked(self, record: Record) -> None:
        sock = self._sock
        if sock is None:
            return  # no worker now: the next one gets the newest stimuli when it starts
        try:
            sock.send(ipc.pack(record))
        except OSError:
            pass  # the worker is gone; the supervisor sees it exit

    def snapshot(self, writes: int = 0) -> dict:
        channels = []
        for c in self.config.channels:
            stim = self.stimuli[c.channel - 1]
            row = {"actuator": c.actuator, "channel": c.channel, "shape": stim.shape, "drive": round(stim.amplitude, 4),
                   "frequency_hz": round(stim.frequency_hz, 3)}
            if c.calibration is not None and stim.shape in ("sine", "pulse") and not stim.silent:
                try:
                    row["peak"] = round(c.calibration.peak_for(stim.frequency_hz, stim.amplitude), 6)
                    row["unit"] = c.calibration.unit
                except AudioConfigError:
                    pass
            channels.append(row)
        return {"name": self.name, "port": self.config.describe(), "path": self.path, "status": self.status,
                "identity": None, "rtt_ms": None,
                "counters": {"blocks": self.blocks, "underruns": self.underruns, "cues": self.generation,
                             "workers": self.workers},
                "connects": self.connects, "disconnects": self.disconnects, "last_error": self.last_error,
                "warning": self.warning, "writer_rt": False, "events": list(self.events)[-20:],
                "audio": {"sample_rate": self.config.sample_rate, "block": self.config.block,
                          "next_sample": self.next_sample, "channels": channels}}

    # ---- the supervisor thread ------------------------------------------------------------------
    def _supervise(self) -> None:
        problems = self.config.check()  # what the file says that cannot work needs no worker to find
        if problems:
            reason = "; ".join(problems)
            log.error("%s: refused: %s", self.name, reason)
            self.last_error = reason
            self._set_status(REFUSED, reason)
            return
        wait = self.reopen_interval_s
        while self._running:
            code = self._run_worker()
            if not self._running or code == EXIT_STOPPED:
                return
            if code == EXIT_REFUSED:
                return  # for good: the message says what to change
            if code != EXIT_ABSENT:  # it was streaming: try again soon
                wait = self.reopen_interval_s
            self._wake.wait(wait)
            wait = min(4.0, wait * 2) if code == EXIT_ABSENT else self.reopen_interval_s

    def worker_command(self, fd: int) -> list[str]:
        return [sys.executable, "-m", "devices.audio.worker", "--fd", str(fd)]

    def _run_worker(self) -> int | None:
        mine, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        try:
            proc = subprocess.Popen(self.worker_command(theirs.fileno()), stdin=subprocess.PIPE,
                                    pass_fds=(theirs.fileno(),), cwd=_ROOT)
        except OSError as exc:
            self._set_status(REFUSED, f"cannot start the audio worker: {exc}")
            return EXIT_REFUSED
        finally:
            theirs.close()
        self.workers += 1
        self._proc = proc
        proc.stdin.write(pickle.dumps(self.config))
        proc.stdin.close()
        with self._send_lock:
            self._sock = mine
            # where the last worker left off (a timed stimulus belonged to its moment: not again)
            self._send_locked(AudioStimuli(self.generation, [(OFF if s.duration is not None else s).to_wire()
                                                             for s in self.stimuli]))
        self._worker_underruns = 0
        silent = False
        try:
            for data in worker_records(mine, self.start_timeout_s):
                if data is None:  # no first report in time: kill it, the loop below sees it exit
                    silent = True
                    proc.kill()
                    continue
                try:
                    self._on_record(ipc.unpack(data, FROM_AUDIO_WORKER))
                except ValueError:
                    log.exception("%s: bad record from the audio worker %r", self.name, data[:80])
        finally:
            with self._send_lock:
                self._sock = None
            mine.close()
        code = proc.wait()
        self._proc = None
        if silent:
            reason = (f"the audio worker did not report within {self.start_timeout_s:g} s (is the audio server "
                      f"of {self.config.describe()} answering?); trying again")
            log.warning("%s: %s", self.name, reason)
            self.last_error = reason
            return EXIT_ABSENT
        if self.status == CONNECTED and self._running:  # it died without a word (killed)
            self.disconnects += 1
            self._set_status(DISCONNECTED, f"the audio worker exited with {code}")
        return code

    def _on_record(self, record: Record) -> None:
        if type(record) is AudioStatus:
            status, reason = record.status, record.reason
            if status == CONNECTED:
                self.connects += 1
                self.last_error = ""
                self.path = self.config.output
            else:
                if status == DISCONNECTED and self.status == CONNECTED:
                    self.disconnects += 1
                if status == REFUSED and self.connects and not is_permanent(reason):
                    status = DISCONNECTED  # it was there: its server is still away, not a bad configuration
                elif reason != self.last_error and status == REFUSED:
                    log.error("%s: refused: %s", self.name, reason)
                self.last_error = reason
            self._set_status(status, reason)
        elif type(record) is AudioCounters:
            blocks, underruns, next_sample = record.blocks, record.underruns, record.next_sample
            took = [tuple(t) for t in record.took]
            self.underruns += underruns - self._worker_underruns
            self._worker_underruns = underruns
            self.blocks, self.next_sample = blocks, next_sample
            self.took.extend(took)
            announced, at = self._underruns_announced
            now = time.monotonic()
            if self.underruns > announced and now - at >= UNDERRUN_REPORT_S and self.on_event is not None:
                self._underruns_announced = (self.underruns, now)
                self.on_event(self.name, UnderrunsCounted(self.underruns))

    def _set_status(self, new: str, reason: str) -> None:
        old, self.status = self.status, new
        if old == new:
            return
        self.events.append({"t": time.time(), "event": "StatusChanged", "old": old, "new": new, "reason": reason})
        if self.on_event is not None:
            self.on_event(self.name, StatusChanged(old, new, reason))


def worker_records(sock: socket.socket, start_timeout_s: float):
    """Each datagram the worker sent, to its end: None once if nothing came within
    `start_timeout_s` (then keep reading: the caller kills the worker, and its end closes)."""
    sock.settimeout(start_timeout_s)
    reset = answered = False
    while True:
        try:
            data = sock.recv(1 << 20)
        except TimeoutError:
            sock.settimeout(None)
            yield None
            continue
        except ConnectionResetError:
            if reset:  # reported once per close: a second one is no worker's doing
                return
            reset = True  # the worker left with stimuli of ours unread: its last records still follow
            continue
        except OSError:
            return
        if not data:
            return
        if not answered:  # from now on it reports every 50 ms until it exits
            answered = True
            sock.settimeout(None)
        yield data
