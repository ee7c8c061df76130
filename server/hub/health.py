"""Health that tells the truth: is the server doing its job right now, and if not, why.

Sans-I/O: the hub feeds it what it learns (child processes starting and exiting, the loop's state,
fault and recovered records, the device host's reports, which devices the running scenario
needs, loop overruns), each with the time on one monotonic clock, and asks `evaluate(now_s)`.
Nothing here reads a clock, a socket or a process, so every rule is tested with made-up times
(tests/hub/test_health.py).

Status: `starting` until the loop's first state record (unless the loop died first; reasons are
listed all the same), then `degraded` while any reason holds, else `ok`. A reason is `{"code", "message", "since_s"}` (`since_s`: how
long the condition has held, seconds); the codes (docs/protocol.md `health`):

- `loop_down`: the loop process is not running (it is being restarted);
- `loop_stalled`: the loop process is alive but no state record came for more than `stall_s`
  (it publishes at 60 Hz, so 50 ms without one means it is not ticking: stopped, starved, stuck);
- `tick_failures`: ticks failed (a `fault` record, or a rising `failures` count in the state
  records) within the last `fault_hold_s` and no `recovered` record came after;
- `device_missing`: a tactile dimension the running scenario requires is shown only by devices
  that are not connected (devices/capability.py `missing`); one reason per such device;
- `device_host_down`: the device host process is not running;
- `device_host_restarted`: for `restart_hold_s` after the device host came back;
- `overruns`: more than `overrun_threshold` loop periods over 1.5 ms within the last
  `overrun_window_s`, not counting the first `startup_grace_s` of a loop process;
- `tracker_lost` (TRACKER_CODES): a tracker source stopped (server/hub/tracker_health.py, fed by
  `trackers` and `tracking`); one reason per such source.

Notes (`notes`, never a reason for `degraded`): a device that is not connected but that the
running scenario does not need (another connected device shows what it would show, or the
scenario requires nothing it shows); a tracker replay that ran once and finished; an audio device
whose underruns rose within the last `overrun_window_s` (`audio_underruns`: its audio server
called for blocks too late, each a gap or a repeated block at the actuator).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Mapping

from devices.capability import CHECK_CABLE, CONNECTED, missing, missing_device_text
from server.hub.tracker_health import TRACKER_CODES, TrackingWatch

OK, DEGRADED, STARTING = "ok", "degraded", "starting"
HOST_DOWN = "unreachable (the device host process is down)"  # a device's status while nobody drives it
CODES = ("loop_down", "loop_stalled", "tick_failures", "device_missing", "device_host_down",
         "device_host_restarted", "overruns")  # the processes' and devices' codes; tracking: TRACKER_CODES
ALL_CODES = CODES + TRACKER_CODES


@dataclass(frozen=True)
class HealthReport:
    status: str
    reasons: tuple[dict, ...] = ()
    notes: tuple[dict, ...] = ()

    @property
    def codes(self) -> frozenset[str]:
        return frozenset(r["code"] for r in self.reasons)


@dataclass
class _Child:
    """What is known of one child process: whether it runs, since when, how it last ended."""
    alive: bool = False
    started_s: float | None = None
    exited_s: float | None = None
    returncode: int | None = None
    restarts: int = 0  # starts after an exit


@dataclass
class Health:
    stall_s: float = 0.05
    fault_hold_s: float = 0.5
    restart_hold_s: float = 2.0
    overrun_threshold: int = 10
    overrun_window_s: float = 10.0
    # A new loop process's first ticks run late (page faults, caches, imports); its death and
    # restart are reported already (loop_down), so its start-up does not count as overruns.
    startup_grace_s: float = 1.0
    loop: _Child = field(default_factory=_Child)
    device_host: _Child = field(default_factory=_Child)

    def __post_init__(self) -> None:
        self._last_state_s: float | None = None  # the last state record, across loop restarts
        self._failures = 0                       # the loop's cumulative failed ticks (since its start)
        self._fault_s: float | None = None       # the last sign of a failing tick
        self._fault_text = ""
        self._recovered_s: float | None = None
        self._overruns: deque[tuple[float, int]] = deque()
        self._overrun_sum = 0
        self._statuses: dict[str, str] = {}
        self._status_since: dict[str, float] = {}
        self._scenario = ""
        self._shown_by: dict[str, tuple[str, ...]] = {}  # required dimension → devices that show it
        self.advice: dict[str, str] = {}  # device → what to do when it is missing (devices/capability.py device_advice)
        self._tracking = TrackingWatch()
        self._underruns: dict[str, tuple[int, float]] = {}  # audio device → (count, when it last rose)

    # ---- inputs: child processes -----------------------------------------------------------
    def loop_started(self, now_s: float) -> None:
        _start(self.loop, now_s)
        self._failures = 0  # a new loop counts its failures from 0

    def loop_exited(self, now_s: float, returncode: int | None = None) -> None:
        _exit(self.loop, now_s, returncode)

    def device_host_started(self, now_s: float) -> None:
        _start(self.device_host, now_s)

    def device_host_exited(self, now_s: float, returncode: int | None = None) -> None:
        _exit(self.device_host, now_s, returncode)
        # Its devices are driven by nobody now; the restarted host reports them again.
        self.devices({name: HOST_DOWN for name in self._statuses}, now_s)

    # ---- inputs: the loop's records --------------------------------------------------------
    def state(self, now_s: float, failures: int = 0, overruns: int = 0) -> None:
        """A state record arrived; `failures`: the loop's cumulative failed ticks it carries,
        `overruns`: the periods over 1.5 ms among the timing samples it carries."""
        self._last_state_s = now_s
        if failures > self._failures:
            self._fault_s = now_s
        self._failures = failures
        started = self.loop.started_s
        if overruns and (started is None or now_s - started >= self.startup_grace_s):
            self._overruns.append((now_s, overruns))
            self._overrun_sum += overruns

    def fault(self, now_s: float, failures: int, error: str = "") -> None:
        self._fault_s = now_s
        self._failures = max(self._failures, failures)
        self._fault_text = error

    def recovered(self, now_s: float, failures: int | None = None) -> None:
        self._recovered_s = now_s
        if failures is not None:
            self._failures = failures

    # ---- inputs: devices -------------------------------------------------------------------
    def devices(self, statuses: Mapping[str, str], now_s: float) -> None:
        """Each device's status as the device host reported it."""
        for name, status in statuses.items():
            if self._statuses.get(name) != status:
                self._status_since[name] = now_s
            self._statuses[name] = status

    def needs(self, scenario: str, shown_by: Mapping[str, tuple[str, ...]]) -> None:
        """The running scenario and, per tactile dimension it requires, the configured devices that
        show it (devices/capability.py `showing`)."""
        self._scenario = scenario
        self._shown_by = dict(shown_by)

    def underruns(self, counts: Mapping[str, int], now_s: float) -> bool:
        """The audio devices' underrun counts (each only rises); True when one rose."""
        rose = False
        for name, count in counts.items():
            if count > self._underruns.get(name, (0, 0.0))[0]:
                self._underruns[name] = (count, now_s)
                rose = True
        return rose

    # ---- inputs: tracking (server/hub/tracker_health.py) ------------------------------------
    def trackers(self, sources, now_s: float) -> bool:
        """Each configured tracker source's health as the tracker host reported it; True when a
        status changed."""
        return self._tracking.sources(sources, now_s)

    def tracking(self, lost, lost_tools, now_s: float) -> bool:
        """The loop's `tracking.lost` sources and the tools they left released; True when changed."""
        return self._tracking.loop(lost, lost_tools, now_s)

    # ---- the verdict -----------------------------------------------------------------------
    def evaluate(self, now_s: float) -> HealthReport:
        reasons: list[dict] = []

        def add(code: str, since: float, message: str) -> None:
            reasons.append({"code": code, "message": message, "since_s": round(max(0.0, now_s - since), 3)})

        loop = self.loop
        restarting = (loop.alive and loop.exited_s is not None and loop.started_s is not None
                      and (self._last_state_s is None or self._last_state_s < loop.started_s))
        if loop.exited_s is not None and (not loop.alive or restarting):  # down until the new one ticks
            add("loop_down", loop.exited_s, f"the haptic loop process exited{_code(loop.returncode)}; the server "
                "is restarting it, and tactile output is off until it is back")
        elif loop.alive and self._last_state_s is not None:
            quiet_since = max(self._last_state_s, loop.started_s or self._last_state_s)
            if now_s - quiet_since > self.stall_s:
                add("loop_stalled", quiet_since, f"the haptic loop has not ticked for {now_s - quiet_since:.2f} s "
                    "although its process runs (stopped, starved of CPU or stuck); tactile output is paused")
        if (self._fault_s is not None and now_s - self._fault_s <= self.fault_hold_s
                and (self._recovered_s is None or self._recovered_s < self._fault_s)):
            last = f"; last error: {self._fault_text}" if self._fault_text else ""
            add("tick_failures", self._fault_s, f"haptic ticks are failing ({self._failures} since the loop "
                f"started{last}); every actuator is off until a tick succeeds. A scenario switch resets it; "
                "the server log has the traceback")

        needed = set()
        for gone in missing(self._shown_by, self._statuses):
            for device, status in zip(gone.devices, gone.statuses):
                needed.add(device)
                add("device_missing", self._status_since.get(device, now_s),
                    missing_device_text(self._scenario, gone.dimension, device, status,
                                        self.advice.get(device, CHECK_CABLE)))

        host = self.device_host
        if host.exited_s is not None and not host.alive:
            add("device_host_down", host.exited_s, f"the device host process exited{_code(host.returncode)}; "
                "the server is restarting it, and no tactile device is driven until it is back")
        elif host.alive and host.restarts and host.started_s is not None \
                and now_s - host.started_s <= self.restart_hold_s:
            add("device_host_restarted", host.started_s, f"the device host process was restarted "
                f"({host.restarts} restart{'s' if host.restarts != 1 else ''}); the devices reconnect by themselves")

        while self._overruns and self._overruns[0][0] <= now_s - self.overrun_window_s:
            self._overrun_sum -= self._overruns.popleft()[1]
        if self._overrun_sum > self.overrun_threshold:
            add("overruns", self._overruns[0][0], f"the haptic loop missed its 1 ms deadline {self._overrun_sum} "
                f"times in the last {self.overrun_window_s:g} s (more than {self.overrun_threshold}): the machine "
                "is overloaded or the loop lacks real-time priority (see telemetry.rt)")

        tracking_reasons, tracking_notes = self._tracking.evaluate(now_s)
        reasons += tracking_reasons
        notes = tuple({"code": "device_disconnected", "since_s": round(now_s - self._status_since[name], 3),
                       "message": f"device '{name}' is {status}; the running scenario does not need it"}
                      for name, status in self._statuses.items() if status != CONNECTED and name not in needed)
        notes += tuple(tracking_notes)
        notes += tuple({"code": "audio_underruns", "since_s": round(now_s - rose_s, 3),
                        "message": f"audio device '{name}' has had {count} underruns; the last within "
                                   f"{self.overrun_window_s:g} s (its audio server is short of CPU)"}
                       for name, (count, rose_s) in self._underruns.items()
                       if count and now_s - rose_s <= self.overrun_window_s)
        if self._last_state_s is None and loop.exited_s is None:
            status = STARTING  # nothing ticks yet; devices may still be identifying themselves
        else:
            status = DEGRADED if reasons else OK
        return HealthReport(status, tuple(reasons), notes)


def _start(child: _Child, now_s: float) -> None:
    if child.alive:
        return
    if child.exited_s is not None:
        child.restarts += 1
    child.alive, child.started_s = True, now_s


def _exit(child: _Child, now_s: float, returncode: int | None) -> None:
    if not child.alive and child.exited_s is not None:
        return
    child.alive, child.exited_s, child.returncode = False, now_s, returncode


def _code(returncode: int | None) -> str:
    if returncode is None:
        return ""
    if returncode < 0:
        return f" (killed by signal {-returncode})"
    return f" (exit code {returncode})"
