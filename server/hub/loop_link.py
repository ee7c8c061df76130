"""The loop link: records from the loop process (state, faults, scene, hello, scenario, log) to
the hub's parts that act on them, and records to it (the injected `send`; the loop supervisor's),
with those that must not be lost retried (`undelivered`). The rig's device reports go to the loop
here too, and every record is handed to the `listeners` after the hub handled it (the recorder)."""

from __future__ import annotations

import logging
import time
from collections import deque
from typing import Callable

from server.hub.browser_actuators import BrowserActuators
from server.hub.control import ScenarioControl
from server.hub.fanout import Fanout
from server.hub.health_feed import HealthFeed
from server.hub.owner import Owner
from server.hub.telemetry import LoopTelemetry
from server.ipc.records import (DeviceReport, FailSafe, Fault, Hello, Log, Malformed, Record, RecordEvery, Recovered,
                                ScenarioAnnounce, SceneAnnounce, State)
from server.wire import messages

log = logging.getLogger("viestac.hub")


class LoopLink:
    def __init__(self, owner: Owner, send: Callable[[Record], bool], *, control: ScenarioControl, fanout: Fanout,
                 health_feed: HealthFeed, tick_hz: int, actuators: BrowserActuators | None = None):
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
        self._host_report: dict = {}  # the device host's last report, before the browser device is merged in
        self.actuators = actuators or BrowserActuators()  # the rig's browser device, if any (the hub drives it)
        self._tracking_lost = False  # the last state record listed a lost tracker source
        self.tracker_applied: deque[list] = deque(maxlen=4096)  # [client_id, seq, t_ms, recv_ns, applied_ns]
        self.log_records: deque[dict] = deque(maxlen=200)
        self.record_every = 0  # trajectory sampling asked of the loop (experiment recorder); 0 = off
        self.undelivered: deque[Record] = deque(maxlen=1024)  # records for the loop that must not be lost (retried)
        self.listeners: list = []  # called with every loop record after the hub handled it (the recorder)

    # ---- records from the loop process -------------------------------------------------
    def on_loop_record(self, record: Record) -> None:
        self.owner.check()
        match record:
            case State():
                self._on_state(record)
            case Fault(failures, _, error):  # a tick failed (Loop; at most once per 100 failing ticks)
                self.health.fault(time.monotonic(), failures, error)
                self.check_health()
            case Recovered(_, failures):
                self.health.recovered(time.monotonic(), failures)
                self.check_health()
            case SceneAnnounce(scene, scene_hash):
                self.fanout.set_scene(scene, scene_hash)
            case Hello(info):
                self.loop_info = info
                self.control.loop_restarted()
                self.telemetry.rt = bool(info.get("rt"))
                if self._device_report is not None:  # a (re)started loop learns the refusals again
                    self.send_to_loop(DeviceReport(self._device_report))
                if self.record_every:
                    self.send_to_loop(RecordEvery(self.record_every))
            case ScenarioAnnounce(info):
                self.control.announced(info)
                self.health_feed.update_needs()
            case Log(level, text):
                log.log(logging.ERROR if level == "error" else logging.WARNING, "loop: %s", text)
                self.log_records.append({"t": time.time(), "level": level, "text": text})
            case FailSafe():
                pass  # the recorder notes it (listeners); the fault record tells health
            case Malformed(error):
                log.error("a bad record from the loop: %s", error)
                return
        for listener in self.listeners:
            listener(record)

    def _on_state(self, state: State) -> None:
        # The devices got this tick's cues already: the loop sent them to the device host's feed.
        timing, view = state.timing, state.view
        overruns = self.telemetry.add(timing.samples)
        now = time.monotonic()
        self.health.state(now, timing.failures, overruns)
        lost = view["tracking"]["lost"]
        if lost or self._tracking_lost:  # a tracker source stopped, or it has just come back
            tools = [t["name"] for t in view["tools"] if t.get("lost")]
            self._tracking_lost = bool(lost)
            if self.health.tracking(lost, tools, now):
                self.check_health()
        self.telemetry.resyncs = timing.resyncs or 0
        if state.recorded.trackers:
            self.tracker_applied.extend(state.recorded.trackers)
        self.states_received += 1
        message = messages.state_message(view, self.telemetry_summary(),  # names the scene the loop simulated
                                         self.actuators.state_field(view))  # what the participant page plays
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
        self.send_to_loop(RecordEvery(every_n_ticks))

    def retry_undelivered(self) -> None:
        """Records the loop's full mailbox refused and nobody could be told of, in order."""
        self.owner.check()
        while self.undelivered and self.send_to_loop(self.undelivered[0]):
            self.undelivered.popleft()

    def browser_changed(self) -> None:
        """The browser device's status changed (a page offered or took away its actuators)."""
        self.on_device_report(self._host_report)

    def on_device_report(self, report: dict) -> None:
        """The rig's report (device host process): refusals no device shows, and each device's
        status, with the browser device's status merged in (the hub drives that one; with no other
        device, its refusals are the rig's). The loop learns it (TickContext.refusals), listeners
        record it."""
        self.owner.check()
        self._host_report = report
        if self.actuators.config is not None:
            host_status = report.get("status") or {}
            report = {**report, "status": {**host_status, **self.actuators.statuses()}}
            if not host_status:
                report["refusals"] = [r.reason for r in self.actuators.refusals]
        statuses = report.get("status") or {}
        if statuses != self.health_feed.device_statuses:
            self.health_feed.devices_reported(statuses)
        if "underruns" in report:  # audio devices (devices/audio/device.py)
            self.health_feed.underruns_reported(report["underruns"])
        if report != self._device_report:
            self._device_report = report
            record = DeviceReport(report)
            self.send_to_loop(record)
            for listener in self.listeners:
                listener(record)
