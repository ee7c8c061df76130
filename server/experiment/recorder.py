"""The recorder: turns the loop's records into rows of the running trial, in batches.

It listens to every record the hub receives from the loop (hub.listeners) and, while a trial
runs, keeps from each state record the trajectory rows (HIP, proxy, contact, carried object;
every Nth tick as the loop was asked), the cue commands whenever they changed, and the events
(the scenario's, every key and command, device status and refusals, tracker loss). The trial's
metrics are what the scenario reported when the trial ended (the record's `finished` entries:
ScenarioOutput.finished). Rows from ticks before the trial's first tick are not the trial's: the
loop announces the tick at which the trial took effect, and rows of earlier ticks in the same state
record belong to the time before it. A state record of a tick before the first tick cannot happen
(ticks never go back, not even across a loop restart: server/hub/supervisor.py); if one came, its
rows are counted and said in a `dropped` event, never lost silently.

A trial whose scenario needs a device that is off is flagged: `begin` gets, per tactile
dimension the trial's scenario requires, the configured devices that show it; the recorder keeps
every device's status from the device reports (`DeviceReport`, also between trials) and adds a
`device_off` event when none of a dimension's devices is connected (at the start, or when it goes
during the trial) and a `device_back` event when one is again. The session view and the export
read the flag from those events (docs/data.md "Trials recorded with a device off").

A loop restart (a `hello` from a new loop process) while a trial is recorded interrupts it: the
rows up to the crash stay with the attempt, and `interrupted` is set so the experiment ends the
attempt as interrupted and retries the trial (docs/data.md "A loop restart during a trial");
nothing of the new loop is added to it.

Nothing here blocks the event loop for long: rows wait in memory and `flush()` writes them in
one transaction per table; the experiment flushes every 0.25 s in a worker thread and always
before a trial changes state, so a finished trial is complete on disk before the next starts.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field

from devices.capability import missing
from server.experiment.store import Store
from server.ipc.records import DeviceReport, FailSafe, Hello, Log, Record, ScenarioAnnounce, State

TRACKER_LOSS_TICKS = 250  # no tracker sample applied for this long (at 1 kHz: 0.25 s) → tracker_lost
# The loop's own tracker-loss events (a source whose samples' ttl passed, and its return:
# server/loop/simulation.py), recorded as kind "tracker" beside the watch below (which notices a
# source without ttl, or any stop of applied samples, after TRACKER_LOSS_TICKS).
LOOP_TRACKER_EVENTS = ("tracker_lost", "tracker_back")


@dataclass
class Active:
    session_id: str
    trial_id: int
    attempt: int
    phase: str | None = None             # the scenario trial the loop must announce (None: no trial)
    index: int = 0
    first_tick: int | None = None        # the tick the trial took effect (None: not yet announced)
    samples: list = field(default_factory=list)
    point_rows: list = field(default_factory=list)  # [tick, {point: [x, y, z]}] when several points are tracked
    cues: list = field(default_factory=list)
    events: list = field(default_factory=list)
    last_cues: list | None = None
    metrics: dict = field(default_factory=dict)  # what the scenario reported when the trial ended
    last_tracker_tick: int | None = None
    tracker_lost: bool = False
    last_tick: int | None = None         # the tick of the last state record recorded
    dropped_records: int = 0             # state records of ticks before first_tick (never expected)
    dropped_samples: int = 0             # trajectory rows in them
    interrupted: str | None = None       # why the attempt stopped before it ended ("loop restart")
    needs: dict = field(default_factory=dict)  # required dimension → the devices that show it
    device_off: bool = False             # a needed device is off now (a device_off event without its device_back)


class Recorder:
    def __init__(self, store: Store):
        self.store = store
        self.active: Active | None = None
        self.loop_pid: int | None = None  # the loop process whose records these are
        self.statuses: dict[str, str] = {}  # each device's status, from the device reports
        self._lock = threading.Lock()  # flush() runs in a worker thread, records arrive on the event loop

    # -- control (the experiment) -----------------------------------------------------------
    def begin(self, session_id: str, trial_id: int, attempt: int, phase: str | None = None, index: int = 0,
              needs: dict | None = None) -> None:
        """Record a trial from the tick the loop announces it: the scenario trial (`phase`,
        `index`), or no trial (`phase` None: training without a trial, a questionnaire).
        `needs`: per required dimension, the devices that show it (a `device_off` event when none
        is connected)."""
        with self._lock:
            self.active = Active(session_id, trial_id, attempt, phase, index, needs=dict(needs or {}))
            self._check_devices(self.active)

    def end(self) -> Active | None:
        """Stop recording the trial and write its remaining rows; returns what was recorded."""
        with self._lock:
            done, self.active = self.active, None
            if done is not None and done.dropped_records:
                done.events.append((done.session_id, done.trial_id, done.attempt, done.last_tick, "dropped",
                                    {"state_records": done.dropped_records, "samples": done.dropped_samples,
                                     "reason": "state records of ticks before the trial's first tick"}))
        if done is not None:
            self._write(done, done.samples, done.cues, done.events, done.point_rows)
        return done

    # -- records from the loop (hub listener) -------------------------------------------------
    def on_record(self, record: Record) -> None:
        if type(record) is Hello:
            self._hello(record.info.get("pid"))
        if type(record) is DeviceReport:
            with self._lock:
                self.statuses.update(record.report.get("status") or {})
        a = self.active
        if a is None or a.interrupted is not None:
            return
        with self._lock:
            match record:
                case ScenarioAnnounce(info):
                    trial = info.get("trial")
                    announced = (None, 0) if trial is None else (trial["phase"], trial["index"])
                    if a.first_tick is None and announced == (a.phase, a.index if a.phase else 0):
                        a.first_tick = int(info.get("tick", 0))
                case State() if a.first_tick is not None:
                    self._state(a, record)
                case DeviceReport(report):
                    a.events.append((a.session_id, a.trial_id, a.attempt, None, "devices", report))
                    self._check_devices(a)
                case FailSafe() | Log():  # stored as the record's fields, in order (docs/data.md)
                    a.events.append((a.session_id, a.trial_id, a.attempt, None, "loop",
                                     {"kind": record.TAG, "detail": record.to_array()[1:]}))

    def _check_devices(self, a: Active) -> None:
        """With the lock held: a `device_off` event when a needed device went (or was gone at the
        start), a `device_back` event when every needed dimension has a connected device again."""
        gone = missing(a.needs, self.statuses)
        if gone and not a.device_off:
            a.device_off = True
            a.events.append((a.session_id, a.trial_id, a.attempt, a.last_tick, "device_off", {
                "devices": sorted({d for m in gone for d in m.devices}), "missing": [m.to_dict() for m in gone],
                "at": "start" if a.first_tick is None else "during"}))
        elif not gone and a.device_off:
            a.device_off = False
            a.events.append((a.session_id, a.trial_id, a.attempt, a.last_tick, "device_back",
                             {"statuses": {d: self.statuses.get(d) for ds in a.needs.values() for d in ds}}))

    def _hello(self, pid: int | None) -> None:
        """A loop process started; if it replaces one, the recorded trial (if any) is interrupted."""
        restarted, self.loop_pid = self.loop_pid is not None and pid != self.loop_pid, pid
        with self._lock:
            a = self.active
            if restarted and a is not None and a.interrupted is None:
                a.interrupted = "loop restart"

    def _state(self, a: Active, state: State) -> None:
        first = a.first_tick
        view, recorded = state.view, state.recorded
        tick = view["tick"]
        rows = recorded.trajectory
        if tick < first:  # ticks went back: not expected (see the module doc); counted, never silent
            a.dropped_records += 1
            a.dropped_samples += len(rows)
            return
        a.samples.extend(row for row in rows if row[0] >= first)
        a.point_rows.extend(row for row in recorded.point_rows if row[0] >= first)
        a.last_tick = tick
        cues = view["cues"]
        if cues != a.last_cues:
            a.cues.append((tick, cues))
            a.last_cues = cues
        for event in view["events"] or ():
            if event.get("tick", tick) < first:
                continue
            name = event.get("name")
            kind = "input" if name == "input" else "tracker" if name in LOOP_TRACKER_EVENTS else "scenario"
            a.events.append((a.session_id, a.trial_id, a.attempt, event.get("tick"), kind, event))
        for done in recorded.finished or ():
            if done["tick"] >= first:
                a.metrics = dict(done["metrics"])
        self._watch_tracker(a, tick, recorded.trackers or ())

    def _watch_tracker(self, a: Active, tick: int, trackers) -> None:
        if trackers:
            if a.tracker_lost:
                a.events.append((a.session_id, a.trial_id, a.attempt, tick, "tracker",
                                 {"name": "tracker_back", "gap_ticks": tick - (a.last_tracker_tick or tick)}))
            a.last_tracker_tick, a.tracker_lost = tick, False
        elif a.last_tracker_tick is not None and not a.tracker_lost and tick - a.last_tracker_tick > TRACKER_LOSS_TICKS:
            a.tracker_lost = True
            a.events.append((a.session_id, a.trial_id, a.attempt, tick, "tracker",
                             {"name": "tracker_lost", "last_tick": a.last_tracker_tick}))

    # -- writing ----------------------------------------------------------------------------
    def flush(self) -> None:
        with self._lock:
            a = self.active
            if a is None:
                return
            rows = a.samples, a.cues, a.events, a.point_rows
            a.samples, a.cues, a.events, a.point_rows = [], [], [], []
        self._write(a, *rows)

    def _write(self, a: Active, samples: list, cues: list, events: list, point_rows: list = ()) -> None:
        self.store.add_samples(a.trial_id, a.attempt, samples)
        self.store.add_point_samples(a.trial_id, a.attempt, point_rows)
        self.store.add_cues(a.trial_id, a.attempt, cues)
        self.store.add_events(events)
