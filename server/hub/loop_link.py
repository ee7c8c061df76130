"""The loop link: records from the loop process (state, faults, scene, hello, scenario, log) to
the hub's parts that act on them, and records to it (the injected `send`; the loop supervisor's),
with those that must not be lost retried (`undelivered`). The rig's device reports go to the loop
here too, and every record is handed to the `listeners` after the hub handled it (the recorder)."""

from __future__ import annotations

import logging
import time
from collections import deque
from typing import Callable

from server.hub.control import ScenarioControl
from server.hub.fanout import Fanout
from server.hub.health_feed import HealthFeed
from server.hub.owner import Owner
from server.hub.telemetry import LoopTelemetry
from server.wire import messages

log = logging.getLogger("viestac.hub")

_NO_TRACKING = {"lost": []}  # a state record without `tracking` (an older loop)


class LoopLink:
    def __init__(self, owner: Owner, send: Callable[[list], bool], *, control: ScenarioControl, fanout: Fanout,
                 health_feed: HealthFeed, tick_hz: int):
        self.owner = owner
        self.send_to_loop = send
        self.control = control
        self.fanout = fanout
        self.health_feed = health_feed
        self.health = health_feed.health
        self.check_health = health_feed.check_health
        self.telemetry = LoopTelemetry(tick_hz=tick_hz)
        self._telemetry_summary: dict = self.telemetry.window()
        self._telemetry_at = 0.0
        self.loop_info: dict = {}
        self.last_state: dict | None = None
        self.states_received = 0
        self._device_report: dict | None = None
        self._tracking_lost = False  # the last state record listed a lost tracker source
        self.tracker_applied: deque[list] = deque(maxlen=4096)  # [client_id, seq, t_ms, recv_ns, applied_ns]
        self.log_records: deque[dict] = deque(maxlen=200)
        self.record_every = 0  # trajectory sampling asked of the loop (experiment recorder); 0 = off
        self.undelivered: deque[list] = deque(maxlen=1024)  # records for the loop that must not be lost (retried)
        self.listeners: list = []  # called with every loop record after the hub handled it (the recorder)

    # ---- records from the loop process -------------------------------------------------
    def on_loop_record(self, record: list) -> None:
        self.owner.check()
        kind = record[0]
        if kind == "state":
            self._on_state(record[1])
        elif kind == "fault":  # a tick failed (LoopCore; at most once per 100 failing ticks)
            self.health.fault(time.monotonic(), record[1].get("failures", 0), record[1].get("error", ""))
            self.check_health()
        elif kind == "recovered":
            self.health.recovered(time.monotonic(), record[1].get("failures"))
            self.check_health()
        elif kind == "scene":
            self.fanout.set_scene(record[1], record[2])
        elif kind == "hello":
            self.loop_info = record[1]
            self.control.loop_restarted()
            self.telemetry.rt = bool(record[1].get("rt"))
            if self._device_report is not None:  # a (re)started loop learns the refusals again
                self.send_to_loop(["devices", self._device_report])
            if self.record_every:
                self.send_to_loop(["record", self.record_every])
        elif kind == "scenario":
            self.control.announced(record[1])
            self.health_feed.update_needs()
        elif kind == "log":
            level = logging.ERROR if record[1] == "error" else logging.WARNING
            log.log(level, "loop: %s", record[2])
            self.log_records.append({"t": time.time(), "level": record[1], "text": record[2]})
        for listener in self.listeners:
            listener(record)

    def _on_state(self, rec: dict) -> None:
        # The devices got this tick's cues already: the loop sent them to the device host's feed.
        overruns = self.telemetry.add(rec["samples"])
        now = time.monotonic()
        self.health.state(now, rec.get("failures", 0), overruns)
        lost = (rec.get("tracking") or _NO_TRACKING)["lost"]
        if lost or self._tracking_lost:  # a tracker source stopped, or it has just come back
            tools = [t["name"] for t in rec.get("tools", ()) if t.get("lost")]
            self._tracking_lost = bool(lost)
            if self.health.tracking(lost, tools, now):
                self.check_health()
        self.telemetry.resyncs = rec.get("resyncs", 0)
        if rec["trackers"]:
            self.tracker_applied.extend(rec["trackers"])
        self.states_received += 1
        message = messages.state_message(rec, self.telemetry_summary())  # names the scene the loop simulated
        self.last_state = message
        self.fanout.publish_state(message)

    def telemetry_summary(self) -> dict:
        now = time.monotonic()
        if now - self._telemetry_at > 0.5:  # percentiles over 10 s of ticks: at most twice a second
            self._telemetry_summary = self.telemetry.window()
            self._telemetry_at = now
        return self._telemetry_summary

    # ---- records to the loop process ---------------------------------------------------------------
    def set_recording(self, every_n_ticks: int) -> None:
        """Ask the loop for trajectory rows every Nth tick (0: none); kept across loop restarts."""
        self.owner.check()
        self.record_every = every_n_ticks
        self.send_to_loop(["record", every_n_ticks])

    def retry_undelivered(self) -> None:
        """Records the loop's full mailbox refused and nobody could be told of, in order."""
        self.owner.check()
        while self.undelivered and self.send_to_loop(self.undelivered[0]):
            self.undelivered.popleft()

    def on_device_report(self, report: dict) -> None:
        """The rig's report (device host process): refusals no device shows, and each device's
        status. The loop learns it (TickContext.refusals), listeners record it."""
        self.owner.check()
        statuses = report.get("status") or {}
        if statuses != self.health_feed.device_statuses:
            self.health_feed.devices_reported(statuses)
        if report != self._device_report:
            self._device_report = report
            self.send_to_loop(["devices", report])
            for listener in self.listeners:
                listener(["devices", report])
