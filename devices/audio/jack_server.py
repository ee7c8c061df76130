"""A JACK server with its dummy driver: a real audio server with no sound card, for the simulated
rig (`viestac emulate audio`), the tests and the bench.

`jackd --no-realtime -n NAME -d dummy -r RATE -p PERIOD -P OUTPUTS -C 0` (Debian's jackd2): the
dummy driver runs the JACK graph every PERIOD frames on the wall clock, so a client (ViESTac's
PortAudio stream, a capture) is called exactly as with a sound card. Each server has its own name
(`-n`), so parallel test runs never meet; clients find it by `JACK_DEFAULT_SERVER` or by name.
"""

from __future__ import annotations

import ctypes
import os
import shutil
import signal
import subprocess
import time
import uuid


class JackError(RuntimeError):
    pass


def jack_module():
    """JACK-Client (`import jack`), imported on first use: the audio extra."""
    try:
        import jack
    except (ImportError, OSError) as exc:
        raise JackError(f"JACK-Client is not available ({exc}): pip install -e '.[audio]' and JACK "
                        "(Debian: jackd2)") from None
    return jack


def _die_with_parent() -> None:
    """In the child before exec: SIGTERM when the parent dies (prctl PR_SET_PDEATHSIG), so a test
    run or an emulator that is killed leaves no server behind (JACK allows only a few at a time)."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)
    except (OSError, AttributeError):
        pass


def unique_name(prefix: str = "viestac") -> str:
    return f"{prefix}-{os.getpid()}-{uuid.uuid4().hex[:6]}"


class JackServer:
    def __init__(self, name: str | None = None, *, rate: int = 48_000, period: int = 64, outputs: int = 2):
        self.name = name or unique_name()
        self.rate, self.period, self.outputs = rate, period, outputs
        self.proc: subprocess.Popen | None = None

    def command(self) -> list[str]:
        jackd = shutil.which("jackd")
        if jackd is None:
            raise JackError("jackd is not installed (Debian: apt-get install jackd2)")
        return [jackd, "--no-realtime", "--sync", "-n", self.name, "-d", "dummy", "-r", str(self.rate), "-p", str(self.period),
                "-P", str(self.outputs), "-C", "0"]

    def start(self, timeout_s: float = 20.0) -> JackServer:
        env = {**os.environ, "JACK_NO_AUDIO_RESERVATION": "1"}  # no D-Bus device reservation
        self.proc = subprocess.Popen(self.command(), env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.PIPE, start_new_session=True, preexec_fn=_die_with_parent)
        deadline = time.monotonic() + timeout_s
        while not self.ready():
            if self.proc.poll() is not None:
                err = self.proc.stderr.read().decode(errors="replace")[-400:] if self.proc.stderr else ""
                raise JackError(f"jackd {self.name} exited with {self.proc.returncode}: {err}")
            if time.monotonic() > deadline:
                self.stop()
                raise JackError(f"jackd {self.name} did not answer within {timeout_s:g} s")
            time.sleep(0.1)
        self.proc.stderr.close()  # nothing reads it from now on: jackd must never block on a full pipe
        self.proc.stderr = None
        return self

    def ready(self) -> bool:
        jack = jack_module()
        try:
            client = jack.Client("viestac-probe", servername=self.name, no_start_server=True)
        except jack.JackError:
            return False
        client.close()
        return True

    @property
    def running(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def stop(self) -> None:
        if self.proc is None:
            return
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.proc = None

    def kill(self) -> None:
        """The server dies (SIGKILL), as a crashed audio server would."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        self.proc = None

    def __enter__(self) -> JackServer:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
