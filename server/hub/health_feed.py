"""The health feed: Health (server/hub/health.py) hears the child processes' starts and exits, the
devices' statuses and profiles, the tracker sources and the loop's faults; it is evaluated every
`HEALTH_EVERY_S` and on every report that can change it, and each client is sent a `health`
message when the status or the set of reason codes changes."""

from __future__ import annotations

import asyncio
import logging
import time
from typing import Callable

from devices.capability import device_advice, showing
from server.hub.health import HOST_DOWN, Health, HealthReport
from server.hub.owner import Owner
from server.wire import messages

log = logging.getLogger("viestac.hub")

HEALTH_EVERY_S = 0.025  # a fault shows in health within 100 ms: 50 ms stall rule + this + a poll


class HealthFeed:
    """`publish(message)`: a `health` message for every client (the fan-out). `scenario_cls()`:
    the scenario the loop runs (ScenarioControl), for the devices it needs."""

    def __init__(self, owner: Owner, *, publish: Callable[[dict], None], scenario_cls: Callable[[], type | None],
                 overrun_threshold: int = 10,
                 requires: Callable[[type], tuple[str, ...]] = lambda cls: tuple(cls.REQUIRES)):
        self.owner = owner
        self.requires = requires  # the dimensions a scenario requires (ScenarioControl.requires: its params too)
        self.publish = publish
        self.scenario_cls = scenario_cls
        self.health = Health(overrun_threshold=overrun_threshold)
        self.report = HealthReport("starting")
        self._published = False
        self.device_statuses: dict[str, str] = {}  # name → status as the device host last reported it
        self._device_profiles: dict = {}
        self.hub_devices: Callable[[], dict] = dict  # the devices the hub drives itself (the browser device): statuses

    @property
    def device_profiles(self) -> dict:
        """name → DeviceProfile as the devices identified themselves (device host)."""
        return self._device_profiles

    @device_profiles.setter
    def device_profiles(self, profiles: dict) -> None:
        self._device_profiles = profiles
        self.health.advice = {name: device_advice(p) for name, p in profiles.items()}
        self.update_needs()

    def update_needs(self) -> None:
        """Which devices show each dimension the running scenario requires (for device_missing)."""
        cls = self.scenario_cls()
        if cls is not None:
            self.health.needs(cls.id, showing(self.requires(cls), self._device_profiles))

    def devices_reported(self, statuses: dict) -> None:
        """The device host's status of each device (only when it changed)."""
        self.device_statuses = dict(statuses)
        self.health.devices(statuses, time.monotonic())
        self.check_health()

    def underruns_reported(self, counts: dict) -> None:
        """The audio devices' underrun counts (reported at most once a second while they rise)."""
        if self.health.underruns(counts, time.monotonic()):
            self.check_health()

    def on_tracker_sources(self, sources: list[dict]) -> None:
        """The tracker host's health of each configured source (every 0.1 s, and when it exits)."""
        self.owner.check()
        if self.health.trackers(sources, time.monotonic()):
            self.check_health()

    def on_child_start(self, what: str) -> None:
        """A child process ("loop" or "device_host") started (the supervisor's on_start hook)."""
        now = time.monotonic()
        (self.health.loop_started if what == "loop" else self.health.device_host_started)(now)
        self.check_health()

    def on_child_exit(self, what: str, returncode: int | None) -> None:
        """A child process exited (the supervisor's on_exit hook)."""
        now = time.monotonic()
        if what == "loop":
            self.health.loop_exited(now, returncode)
        else:
            self.health.device_host_exited(now, returncode)
            # nobody drives them now; the restarted host reports them again (the hub's own go on)
            hub_devices = self.hub_devices()
            self.device_statuses = {**{name: HOST_DOWN for name in self._device_profiles if name not in hub_devices},
                                    **hub_devices}
        self.check_health()

    async def watch_health(self, children: dict, each_poll: Callable[[], None] = lambda: None) -> None:
        """Every HEALTH_EVERY_S: poll the child processes (`children`: "loop" / "device_host" →
        ChildProcess), run `each_poll` (the loop link's retries), then evaluate health. The poll
        stands in until the children report their starts and exits themselves; on_child_start and
        on_child_exit take either."""
        seen: dict[str, object] = {what: None for what in children}  # the process last seen running
        while True:
            for what, child in children.items():
                proc = child.proc if child.alive else None
                if proc is not seen[what]:
                    if seen[what] is not None:  # it died (and may be running again already: a new process)
                        self.on_child_exit(what, seen[what].returncode)
                    if proc is not None:
                        self.on_child_start(what)
                    seen[what] = proc
            each_poll()
            self.check_health()
            await asyncio.sleep(HEALTH_EVERY_S)

    def check_health(self) -> HealthReport:
        """Evaluate health now; clients are sent a `health` message when the status or the set of
        reason codes changed."""
        report = self.health.evaluate(time.monotonic())
        previous, self.report = self.report, report
        if not self._published or (report.status, report.codes) != (previous.status, previous.codes):
            if report.status != previous.status:
                log.log(logging.INFO if report.status == "ok" else logging.WARNING, "health: %s%s", report.status,
                        "".join(f"; {r['message']}" for r in report.reasons))
            self.publish(messages.health(report.status, list(report.reasons)))
            self._published = True
        return report
