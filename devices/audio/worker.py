"""The audio worker process: one audio device's PortAudio stream (devices/audio/shell.py).

Started by the device host's AudioDevice (devices/audio/device.py) as
`python -m devices.audio.worker --fd N` with the pickled AudioConfig on stdin; N is its end of a
SEQPACKET socket pair. Its records (server/ipc/records.py, docs/architecture.md "The mailbox"):
`AudioStimuli` (every output channel's newest stimulus) and `Stop` from the host; `AudioStatus`
and `AudioCounters` (every 50 ms and after a hand-over) to it.

A receiving thread publishes each stimuli message to the stream's single slot; it asks for
SCHED_FIFO below the loop when allowed (devices/realtime.py), like the serial writers: a cue that
wakes it while both cores are busy otherwise waited for a CPU long enough to miss the next audio
cycle, or several (docs/performance.md "Audio tactor"). The main thread
watches the stream: when it stops (the audio server died: the callbacks cease and PortAudio marks
it inactive) it reports `disconnected` and leaves with os._exit, without touching PortAudio, whose
stop and terminate would wait for ever on a dead JACK server. Exit codes: 0 stopped, 3 the stream
died, 4 refused for good (the configuration cannot work), 5 refused for now (the output is not
there: is its server running?).
"""

from __future__ import annotations

import argparse
import logging
import os
import pickle
import socket
import sys
import threading
import time

from devices.audio.config import AudioConfigError
from devices.audio.shell import AudioOutput, portaudio
from devices.audio.synth import Stimulus
from devices.realtime import fifo_this_thread
from server import ipc
from server.ipc.records import TO_AUDIO_WORKER, AudioCounters, AudioStatus, AudioStimuli, Record, Stop

log = logging.getLogger("viestac.devices")

EXIT_STOPPED, EXIT_DIED, EXIT_REFUSED, EXIT_ABSENT = 0, 3, 4, 5
PERMANENT = ("channel ", "unsupported sample rate", "the calibration")


def is_permanent(message: str) -> bool:
    """A refusal a restart cannot cure (versus an output that is not there yet)."""
    return any(part in message for part in PERMANENT)


def run(config, sock: socket.socket, *, stall_s: float = 1.5) -> int:
    def send(record: Record) -> None:
        try:
            sock.send(ipc.pack(record))
        except OSError:
            pass

    problems = config.check()
    if problems:
        send(AudioStatus("refused", "; ".join(problems)))
        return EXIT_REFUSED
    output = AudioOutput(config)
    try:
        output.open(portaudio(config.jack_server))
    except AudioConfigError as exc:
        send(AudioStatus("refused", str(exc)))
        return EXIT_REFUSED if is_permanent(str(exc)) else EXIT_ABSENT
    except Exception as exc:  # noqa: BLE001 - PortAudio's own errors: the output is not usable now
        send(AudioStatus("refused", f"cannot open {config.describe()}: {exc}"))
        return EXIT_ABSENT
    send(AudioStatus("connected", f"streaming to {output.device_name} at {config.sample_rate} Hz, "
                                  f"{config.block}-frame blocks"))
    stopping = threading.Event()
    kick = threading.Event()

    def receive() -> None:
        fifo_this_thread()
        while True:
            try:
                data = sock.recv(1 << 20)
            except OSError:
                data = b""
            if not data:
                break
            try:
                record = ipc.unpack(data, TO_AUDIO_WORKER)
                if type(record) is Stop:
                    break
                if type(record) is AudioStimuli:
                    output.publish(record.generation, tuple(Stimulus.from_wire(s) for s in record.stimuli))
                    kick.set()
            except (ValueError, TypeError):  # a bad record is reported and survived
                log.exception("audio worker: bad record %r", data[:80])
        stopping.set()
        kick.set()

    threading.Thread(target=receive, name="audio-receive", daemon=True).start()
    count, last_blocks, last_change = 0, -1, time.monotonic()
    while not stopping.is_set():
        kick.wait(0.05)
        kick.clear()
        if output.taken != output.published:
            time.sleep(2 * config.block / config.sample_rate)  # report the hand-over once it happened
        now = time.monotonic()
        if output.blocks != last_blocks:
            last_blocks, last_change = output.blocks, now
        elif now - last_change > stall_s or not output.alive:
            send(AudioStatus("disconnected", f"no audio callback for {now - last_change:.2f} s: the audio server "
                                             "stopped or the output is gone"))
            return EXIT_DIED
        count, took = output.took_since(count)
        send(AudioCounters(output.blocks, output.underruns, output.synth.sample, [list(t) for t in took]))
    # a stop: the host sent silence first and waited for its release
    try:
        output.stream.stop()
        output.stream.close()
    except Exception:  # noqa: BLE001 - the exit handler tries again; the watchdog bounds it
        pass
    return EXIT_STOPPED


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="viestac-audio-worker")
    parser.add_argument("--fd", type=int, required=True)
    args = parser.parse_args(argv)
    config = pickle.loads(sys.stdin.buffer.read())  # from the device host, our parent: trusted
    sock = socket.socket(fileno=args.fd)
    code = run(config, sock)
    sys.stdout.flush()
    if code == EXIT_DIED:
        os._exit(code)  # never PortAudio's exit handler: on a dead JACK server it waits for ever
    # A clean goodbye otherwise (the stream closed, the JACK client leaves the graph at once; a
    # vanished client would hold a synchronous server's graph up until its timeout), unless that
    # hangs too: the server may have died just now.
    watchdog = threading.Timer(3.0, os._exit, (code,))
    watchdog.daemon = True
    watchdog.start()
    return code


if __name__ == "__main__":
    sys.exit(main())
