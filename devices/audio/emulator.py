"""`viestac emulate audio`: a voice-coil tactor for the simulated rig — a JACK server with its
dummy driver (the sound interface) and a capture client that writes what arrives at its outputs as
the actuator timeline (devices/audio/capture.py `Timeline`), like the serial emulators' edges.

    viestac emulate audio [--server NAME] [--link FILE] [--timeline FILE.csv] [--outputs 2]
                          [--rate 48000] [--period 64] [--realtime]

Once the server answers, it writes the server's name to `--link` (the simulated rig waits for that
file, as for a serial emulator's link) and prints it; ViESTac reaches it through PortAudio's JACK
host API (`jack_server = NAME` in a rig file's [device.audio]). Stops on SIGTERM/SIGINT, and with
its parent under `--exit-with-parent`; the link file goes with it. `--realtime`: jackd with
real-time priority when this process may use SCHED_FIFO (a sound card keeps its clock whatever the
computer does; the simulated rig asks for it, as for the serial emulators).
"""

from __future__ import annotations

import argparse
import ctypes
import signal
import sys
import threading
from pathlib import Path

from devices.audio.capture import Capture, Timeline
from devices.audio.jack_server import JackError, JackServer, jack_module, realtime_allowed, unique_name


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="viestac emulate audio", description=__doc__.split("\n\n")[0])
    parser.add_argument("--server", default=None, help="the JACK server's name (default: a fresh unique one)")
    parser.add_argument("--link", type=Path, default=None, help="write the server's name here once it answers")
    parser.add_argument("--timeline", type=Path, default=None, help="the actuator timeline CSV")
    parser.add_argument("--append-timeline", action="store_true", help="append to the timeline (a restart)")
    parser.add_argument("--outputs", type=int, default=2, help="the interface's output channels (default 2)")
    parser.add_argument("--rate", type=int, default=48_000)
    parser.add_argument("--period", type=int, default=64, help="frames per JACK cycle (default 64)")
    parser.add_argument("--exit-with-parent", action="store_true", help="stop when the parent process dies")
    parser.add_argument("--realtime", action="store_true", help="jackd at SCHED_FIFO 20 when allowed")
    args = parser.parse_args(argv)
    if args.exit_with_parent:
        try:
            ctypes.CDLL(None).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass
    jack = jack_module()
    jack.set_error_function(lambda message: None)  # "cannot connect" while the server starts
    jack.set_info_function(lambda message: None)
    done = threading.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: done.set())
    server = JackServer(args.server or unique_name("viestac-audio"), rate=args.rate, period=args.period,
                        outputs=args.outputs, realtime=args.realtime and realtime_allowed())
    for attempt in range(20):  # a restart: the last server of this name may still be shutting down
        try:
            server.start()
            break
        except JackError:
            if attempt == 19 or done.wait(0.5):
                raise
    capture = timeline = None
    try:
        capture = Capture(server.name, args.outputs, seconds=10.0).start()
        if args.timeline is not None:
            timeline = Timeline(capture, args.timeline, names=tuple(f"out_{k + 1}" for k in range(args.outputs)),
                                append=args.append_timeline)
        if args.link is not None:
            tmp = args.link.with_name(args.link.name + ".tmp")
            tmp.write_text(server.name + "\n")
            tmp.replace(args.link)  # appears whole
        print(f"audio emulator: JACK server {server.name} ({args.outputs} outputs, {args.rate} Hz, "
              f"{args.period}-frame cycles)" + (f", timeline {args.timeline}" if args.timeline else ""), flush=True)
        while not done.wait(0.02):
            if not server.running:
                print("audio emulator: the JACK server exited", file=sys.stderr)
                return 1
            if timeline is not None:
                timeline.poll()
        return 0
    finally:
        if args.link is not None:
            args.link.unlink(missing_ok=True)
        if timeline is not None:
            timeline.close()
        if capture is not None:
            capture.stop()
        server.stop()


if __name__ == "__main__":
    sys.exit(main())
