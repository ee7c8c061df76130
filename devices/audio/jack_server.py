"""A JACK server with its dummy driver: a real audio server with no sound card, for the simulated
rig (`viestac emulate audio`), the tests and the bench.

`jackd --no-realtime -n NAME -d dummy -r RATE -p PERIOD -P OUTPUTS -C 0` (Debian's jackd2): the
dummy driver runs the JACK graph every PERIOD frames on the wall clock, so a client (ViESTac's
PortAudio stream, a capture) is called exactly as with a sound card. Each server has its own name
(`-n`), so parallel test runs never meet; clients find it by `JACK_DEFAULT_SERVER` or by name.

`realtime=True` (the simulated rig and the bench, when this process may use SCHED_FIFO) runs it
as `jackd --realtime -P 20` instead: a sound card keeps its own clock whatever the computer does,
and a dummy driver without real-time priority on a loaded machine runs its cycles late (xruns by
the hundred: docs/performance.md "Audio tactor"). JACK gives its clients' process threads, ViESTac's
audio callback among them, real-time priority too. 20 is the serial emulators' priority, below
the loop's 50.
"""

from __future__ import annotations

import ctypes
import os
import shutil
import signal
import subprocess
import threading
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


REALTIME_PRIORITY = 20


def realtime_allowed() -> bool:
    """May this process (and so a jackd it starts) use SCHED_FIFO? Asked in a thread of its own,
    which ends at once: the caller's threads keep their scheduling."""
    allowed = []

    def probe() -> None:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
            allowed.append(True)
        except (PermissionError, OSError, AttributeError):
            pass

    thread = threading.Thread(target=probe, name="rt-probe")
    thread.start()
    thread.join()
    return bool(allowed)


# JACK's server registry (jack2's shm.h): a shared segment with a slot {pid, name} for each of at
# most 8 servers, guarded by a System V semaphore. A server that does not exit cleanly (killed,
# or a real-time one that outlived its SIGTERM grace) keeps its slot, and jackd reclaims a dead
# server's slot only for a server of the same name: after 8 of them no server starts anywhere on
# the machine ("Too many servers already active").
REGISTRY = "/dev/shm/jack-shm-registry"
_REGISTRY_SEM_KEY = 0x282929
_SLOTS_AT, _SLOT_BYTES, _SLOTS = 24, 264, 8


class _SemBuf(ctypes.Structure):
    _fields_ = [("sem_num", ctypes.c_ushort), ("sem_op", ctypes.c_short), ("sem_flg", ctypes.c_short)]


def _registry_lock(op: int) -> bool:
    libc = ctypes.CDLL(None, use_errno=True)
    sem = libc.semget(_REGISTRY_SEM_KEY, 1, 0)
    if sem < 0:
        return False
    return libc.semop(sem, ctypes.byref(_SemBuf(0, op, 0x1000)), 1) == 0  # SEM_UNDO


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    return True


def free_dead_server_slots(registry: str = REGISTRY) -> list[str]:
    """Clear the registry slots of servers whose process is gone (under JACK's own lock); returns
    their names. Called when jackd found no free slot."""
    freed = []
    try:
        fd = os.open(registry, os.O_RDWR)
    except OSError:
        return freed
    locked = _registry_lock(-1)
    try:
        for i in range(_SLOTS):
            at = _SLOTS_AT + i * _SLOT_BYTES
            raw = os.pread(fd, _SLOT_BYTES, at)
            if len(raw) < _SLOT_BYTES:
                break
            pid = int.from_bytes(raw[:4], "little", signed=True)
            if pid > 0 and not _alive(pid):
                freed.append(raw[4:].split(b"\0", 1)[0].decode(errors="replace"))
                os.pwrite(fd, bytes(_SLOT_BYTES), at)
    finally:
        if locked:
            _registry_lock(1)
        os.close(fd)
    return freed


def unique_name(prefix: str = "viestac") -> str:
    return f"{prefix}-{os.getpid()}-{uuid.uuid4().hex[:6]}"


class JackServer:
    def __init__(self, name: str | None = None, *, rate: int = 48_000, period: int = 64, outputs: int = 2,
                 realtime: bool = False):
        self.name = name or unique_name()
        self.rate, self.period, self.outputs = rate, period, outputs
        self.realtime = realtime
        self.proc: subprocess.Popen | None = None

    def command(self) -> list[str]:
        jackd = shutil.which("jackd")
        if jackd is None:
            raise JackError("jackd is not installed (Debian: apt-get install jackd2)")
        scheduling = ["--realtime", "-P", str(REALTIME_PRIORITY)] if self.realtime else ["--no-realtime"]
        return [jackd, *scheduling, "--sync", "-n", self.name, "-d", "dummy", "-r", str(self.rate), "-p",
                str(self.period), "-P", str(self.outputs), "-C", "0"]

    def start(self, timeout_s: float = 20.0) -> JackServer:
        try:
            return self._start(timeout_s)
        except JackError as exc:
            if "Too many servers" not in str(exc) or not free_dead_server_slots():
                raise
        return self._start(timeout_s)

    def _start(self, timeout_s: float) -> JackServer:
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
