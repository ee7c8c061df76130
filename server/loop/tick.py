"""Loop: the whole tick of the 1 kHz loop, as data in and data out.

`tick(records, now_ns)` is one tick: the records that arrived since the last one (tracker
samples, keys and commands, trials, scenario switches, device reports) are applied, then one
simulation step, then what has to go out comes back as a TickOutput: the device cues to hand
over when they differ from what the devices were last given, the records for the hub (scene and
scenario announcements, log lines, `fail_safe`) and the state record when one is due. The
drivers only move data: the loop process (process.py: sockets, sleeping, priority), the
simulated study's virtual hub (server/simulate/virtual_hub.py: virtual devices, virtual clock)
and offline rendering (server/render.py). Tests drive this class directly on a virtual clock.

A state record is due on the regular cadence (state_hz, 60 by default) AND in any tick whose
cues changed, so the picture of that tick leaves with its device command and a tactile cue never
leads the picture (haptic-before-visual is noticed from ~15 ms, Di Luca & Mahnan 2019). The
device command itself leaves first, on a channel of its own: the process sends it straight to the
device host process's feed thread, past the hub's event loop. Scenario events and trial ends
ride with the next state record, each stamped with its tick, so none is lost between publishes.

A failing tick (an exception in a scenario, or in the god-object) does not stop the loop: every
actuator goes off through the cue output, a `fail_safe` record and the error go to the hub, the
tools forget their god-object state, the tick counter advances, and the next good tick sends its
cues again whatever they are. Failures are counted (`failures` in every state record) and
reported as a `Fault` record (server/ipc/records.py) at the first failure of a streak and at most
every FAULT_REPORT_EVERY ticks while it lasts, then `Recovered` at the first good tick; both come out in `TickOutput.faults` (the hub reads them for health).

A scenario switch is built outside the tick. Building one takes milliseconds (a scene of many
bodies: 8-17 ms for the positioning tasks), more than a tick's period, so with `build_off_tick`
(the loop process) `apply(SwitchScenario(...))` only checks the name and records the switch as
`pending_switch`; the driver builds it with `build()` off the tick (any thread: it reads nothing
of the core) and hands it in with `install()` between ticks. Until then the running scenario
goes on: tracker samples, keys and commands apply to it, while `trial` records wait and apply to
the new scenario right after it is installed (the hub sends a trial after the switch it is for).
A second switch during a build supersedes the first (latest wins: its build is discarded with
any trial waiting for it), so a burst of switches ends on the last one asked for. Without
`build_off_tick` (the virtual hub, rendering, tests: no real-time tick to protect) apply()
builds and installs at once through the same two calls. The new scene and scenario are announced
when the switch is installed.

Tracker samples go through the tracker rule of the tool they move (server/core/tool.py): one
source drives the HIP; `TrackerGone` sends it home when its driver leaves. Records in and out are
the typed records of server/ipc/records.py; `apply` dispatches on their class.
"""

from __future__ import annotations

import traceback
from array import array
from dataclasses import dataclass
from typing import Callable, Mapping

from server.core.cues import cue_to_wire
from server.core.records import TIMING_SAMPLE
from scenarios import registry
from server.core.scenario import NO_TOOL_CUES
from server.core.scenario import Trial as TrialSpec
from server.ipc.records import (DeviceReport, FailSafe, Fault, Input, Log, Malformed, Record, RecordEvery, Recorded,
                                Recovered, ScenarioAnnounce, SceneAnnounce, State, SwitchScenario, Timing, TrackerGone,
                                TrackerSample, Trial)
from server.loop.cadence import STATE_HZ
from server.loop.simulation import Simulation, TickResult
from server.loop.state_view import StateView, rounded as _round

MAX_REPORTED_FAILURES = 10  # a failing scenario fails every tick: report the first ones, then every 1000th
FAULT_REPORT_EVERY = 100  # ticks: a `fault` record at a streak's first failure, then at most this often
MAX_FAULT_TEXT = 300  # characters of the exception in a `fault` record
MAX_CARRIED_TIMING = 4000  # timing samples an unsent state record passes on; rows and events all go
IGNORED_NOTICE_EVERY = 1000  # a source that is not the driver: one log line at its first ignored sample, then every Nth


@dataclass(frozen=True, eq=False)  # compared by identity: two asks for the same scenario are two switches
class Switch:
    """A scenario switch asked of the loop, not yet installed."""
    name: str
    params: dict
    seed: int
    number: int = 0  # the hub's number for it, echoed as `switch` in the announcements (0: unnumbered)


def finger_cues(output, tools) -> dict[str, list[dict]]:
    """The wire cues of every tool but the primary, by name (a tool the scenario gave none: [])."""
    given = output.tool_cues
    if not given:  # no finger has a cue (the default, shared NO_TOOL_CUES): every list is empty
        return {tool.name: [] for tool in tools[1:]}
    return {tool.name: [cue_to_wire(c) for c in given.get(tool.name, ())] for tool in tools[1:]}


class TickOutput:
    """What one tick produced. One object per core, refilled every tick (the 1 kHz path allocates
    nothing it can avoid): read it before the next tick. The state record and the record lists it
    points to are new each time and may be kept."""

    __slots__ = ("tick", "result", "cues", "finger_cues", "records", "faults", "state", "error")

    def __init__(self) -> None:
        self.tick = -1
        self.result: TickResult | None = None  # None: the step failed (fail-safe)
        self.cues: list[dict] | None = None  # wire form; hand to the devices (before the state); None: unchanged
        # With `cues`, when the simulation has several tools: {tool name: wire cues} of the other
        # tools (every one listed; [] = off); the devices of a finger get its list (devices/feed.py).
        self.finger_cues: dict[str, list[dict]] | None = None
        self.records: list[Record] | tuple = ()  # for the hub, in order, before the state record
        # Fault / Recovered records for the hub's health, sent after `records`, before the state
        self.faults: list[Record] | tuple = ()
        self.state: State | None = None  # the state record, when one is due
        self.error: str | None = None  # why the step failed (also in `records` as a log line)


class Loop:
    def __init__(self, sim: Simulation, *, state_hz: float = STATE_HZ,
                 make_sim: Callable[..., Simulation] | None = None, build_off_tick: bool = False,
                 drawn: bool = True):
        if not 0 < state_hz <= sim.tick_hz:
            raise ValueError("state_hz must be in (0, tick_hz]")
        # False: no client draws this run's state (the simulated study's virtual hub): a state
        # record carries only what the hub's recorder and a synthetic participant read (StateView.undrawn).
        self.drawn = drawn
        sim.drawn = drawn
        self.sim = sim
        self.make_sim = make_sim or (lambda scenario, seed: Simulation(scenario, tick_hz=sim.tick_hz, seed=seed,
                                                                       rig=sim.rig))
        self.params: dict = {}
        self.seed = 0
        self.outbox: list[Record] = []  # records for the hub besides state (scene and scenario changes, logs)
        self.state_hz = state_hz
        self._publish_slot = -1      # index of the last cadence slot published
        self.samples = array("q")    # TIMING_SAMPLE rows since the last state record (records.py)
        self.tracker_applied: list[list] = []  # [client_id, seq, t_ms, recv_ns, applied_ns]
        self.states_unsent = 0       # state records the driver could not send; their contents went out later
        self.frames = 0
        self.failures = 0            # ticks that failed since start
        self.resyncs: int | None = None  # the driver's deadline scheduler's resyncs (Timing), if it has one
        self._failing = False        # the last tick failed (a `recovered` record follows the next good one)
        self._fault_reported_tick = 0
        self._faults: list[Record] = []  # this tick's Fault / Recovered records (TickOutput.faults)
        self.record_every = 0        # trajectory sampling: every Nth tick while an experiment records; 0 = off
        self.trajectory: list[list] = []  # rows since the last state record (server/core/records.py TRAJECTORY_COLUMNS)
        self.point_rows: list[list] = []  # [tick, {point: [x, y, z]}] with them, when several points are tracked
        self._device_cues: tuple | None = None  # what the devices were last given; None: unknown (start)
        self._device_tool_cues: Mapping | None = None  # and the other tools' devices (ScenarioOutput.tool_cues)
        self._out = TickOutput()
        self.view = StateView()  # builds what clients see of a state record, rounding each value once
        self.build_off_tick = build_off_tick  # True: the driver builds a switch off the tick (module doc)
        self.pending_switch: Switch | None = None  # asked, not yet installed
        self.switch = 0  # the number of the last switch installed or abandoned (the hub matches its own by it)
        self._waiting: list[Trial] = []  # trial records for the pending switch's scenario

    # -- the tick --------------------------------------------------------------------------------
    def tick(self, records, now_ns: int) -> TickOutput:
        """Apply `records` (a bad one is reported, never fatal), step once, and say what goes out."""
        for record in records:
            try:
                self.apply(record, now_ns)
            except Exception:  # noqa: BLE001 - a bad switch or trial must not kill the loop
                self.outbox.append(Log("error", f"record {getattr(record, 'TAG', '?')} failed: "
                                                f"{traceback.format_exc()}"))
        out = self._out
        sim = self.sim
        tick = sim.data.tick
        try:
            result, state = self.step(now_ns)
            out.cues = self.device_cues(result)
            out.error = None
        except Exception as exc:  # noqa: BLE001 - a scenario bug must not kill the loop: fail safe, report
            result = state = None
            out.cues = self._fail_safe(tick, exc)
        else:
            if self._failing:  # the first good tick after failing ones
                self._failing = False
                self._faults.append(Recovered(tick, self.failures))
        out.tick, out.result, out.state = tick, result, state
        if self.outbox:
            out.records, self.outbox = self.outbox, []
        else:
            out.records = ()
        if self._faults:
            out.faults, self._faults = self._faults, []
        else:
            out.faults = ()
        return out

    def _fail_safe(self, tick: int, exc: BaseException) -> list | None:
        """A failed step: actuators off, the failure counted and reported (`fault`), and every
        tool's god-object forgotten, so the next good sample renders from scratch instead of
        from a proxy the failure left behind (a proxy stuck at 1e154 failed every tick after)."""
        self.failures += 1
        sim = self.sim
        cues = self.fail_safe_cues()  # every device off; the next good tick sends its cues again
        if sim.data.cues:
            sim.data.cues = ()
            self.outbox.append(FailSafe())
        for tool in sim.data.tools:
            tool.reset_proxy()
        sim.data.tick = tick + 1
        error = self._out.error = traceback.format_exc()
        if not self._failing or tick - self._fault_reported_tick >= FAULT_REPORT_EVERY:
            self._fault_reported_tick = tick
            self._faults.append(Fault(self.failures, tick, f"{type(exc).__name__}: {exc}"[:MAX_FAULT_TEXT]))
        self._failing = True
        if self.failures <= MAX_REPORTED_FAILURES or self.failures % 1000 == 0:
            self.outbox.append(Log("error", f"tick failed ({self.failures}): {error}"))
        return cues

    # -- records in (between ticks) --------------------------------------------------------------
    def apply(self, record: Record | Malformed, now_ns: int) -> None:
        """Apply one record from the hub (between ticks)."""
        sim = self.sim
        match record:
            case TrackerSample():
                self._offer(record, now_ns)
            case TrackerGone(client_id):  # a source left; the tools it drove go home
                sim.release(client_id)
            case Input(client_id, key, action, value):  # checked by the hub
                sim.input(key, action, value)
                # every key and command is recorded with the tick it took effect
                data = sim.data
                data.events.append({"tick": data.tick, "t": data.tick / sim.tick_hz, "name": "input",
                                    "client": client_id, "key": key, "action": action, "value": value})
            case Trial(body):  # checked by the hub
                if self.pending_switch is not None:  # for the scenario being built: applied when it is installed
                    self._waiting.append(record)
                    return
                trial = None if body is None else TrialSpec.parse(type(sim.scenario).TRIAL_PARAMS, body.get("phase"),
                                                                  body.get("params"), body.get("index", 0))
                sim.set_trial(trial)
                self.outbox.append(self.scenario_record())
            case SwitchScenario(name, params, seed, number):  # between trials (module doc)
                registry.resolve(name)  # an unknown name is reported now, not after a build
                self.ask_switch(Switch(name, dict(params), seed, number))
            case RecordEvery(every_n_ticks):  # trajectory rows ride with the state records
                self.record_every = max(0, int(every_n_ticks))
                self.trajectory = []
                self.point_rows = []
            case DeviceReport(report):  # the device manager's refusals, for the scenario (TickContext.refusals)
                sim.data.refusals = tuple(str(text) for text in report.get("refusals", ()))
            case Malformed(error):
                self.outbox.append(Log("error", f"a bad record from the hub: {error}"))
            case _:
                raise TypeError(f"not a record for the loop: {record!r:.80}")

    def _offer(self, sample: TrackerSample, now_ns: int) -> None:
        """A tracker sample to the tool it moves; a sample of a source that does not drive it is
        said in the log (the first, then every IGNORED_NOTICE_EVERY-th)."""
        sim = self.sim
        pos, point, points = sample.pos, sample.point, sample.points
        if points:
            points = {name: (float(p[0]), float(p[1]), float(p[2])) for name, p in points.items()}
        if sim.offer(sample.source, sample.seq, (float(pos[0]), float(pos[1]), float(pos[2])), point, points,
                     sample.ttl_ms):
            self.tracker_applied.append([sample.source, sample.seq, sample.t_ms, sample.recv_ns, now_ns])
            return
        tool = sim.data.tool_by_name.get(point or sim.data.tools[0].name, sim.data.tools[0])
        ignored = tool.ignored.get(sample.source, 0)
        if ignored == 1 or ignored % IGNORED_NOTICE_EVERY == 0:
            what = "the HIP" if tool is sim.data.tools[0] else tool.name
            self.outbox.append(Log("warning", f"tracker samples from {sample.source} ignored: {tool.driver} "
                                              f"drives {what} ({ignored} ignored so far)"))

    # -- scenario switches (module doc) -------------------------------------------------------------
    def ask_switch(self, switch: Switch) -> None:
        """Record a switch; it supersedes one still pending (latest wins). Built here unless the
        driver builds off the tick."""
        if self.pending_switch is not None:
            self._waiting.clear()  # trials for the superseded scenario
            self.outbox.append(Log("warning", f"scenario switch to {self.pending_switch.name} superseded by "
                                              f"{switch.name} before it was built"))
        self.pending_switch = switch
        if not self.build_off_tick:
            self.install(switch, self.build(switch))

    def build(self, switch: Switch) -> Simulation:
        """The new simulation (scenario, scene, bodies). Reads nothing of the core: safe off the
        tick's thread."""
        return self.make_sim(registry.create(switch.name, **switch.params), switch.seed)

    def install(self, switch: Switch, sim: Simulation) -> bool:
        """Put a built switch in place (between ticks); False if a later switch superseded it."""
        if switch is not self.pending_switch:
            return False
        self.pending_switch = None
        self.switch = switch.number
        self._take_over(sim, switch.params, switch.seed)
        waiting, self._waiting = self._waiting, []
        for record in waiting:
            try:
                self.apply(record, 0)
            except Exception:  # noqa: BLE001 - as in tick(): a bad record is reported, never fatal
                self.outbox.append(Log("error", f"record {record.TAG} failed: {traceback.format_exc()}"))
        return True

    def abandon(self, switch: Switch, error: str) -> None:
        """A switch whose build failed: reported; the running scenario goes on."""
        self.outbox.append(Log("error", f"record scenario failed: {error}"))
        if switch is self.pending_switch:
            self.pending_switch = None
            if self._waiting:
                self.outbox.append(Log("error", f"{len(self._waiting)} trial record(s) for {switch.name} dropped: "
                                                "its scenario could not be built"))
                self._waiting = []
            # the hub counts this switch as in flight until it hears of it: say what runs instead
            self.switch = switch.number
            record = self.scenario_record()
            record.info["failed"] = switch.name
            self.outbox.append(record)

    def _take_over(self, sim: Simulation, params: dict, seed: int) -> None:
        """`sim` replaces the running simulation; announces the new scene."""
        sim.data.carry_over(self.sim.data)  # the tick, unpublished events, who drives what (SimData)
        sim.drawn = self.drawn
        self.sim, self.params, self.seed = sim, dict(params), seed
        self.outbox.extend(self.announce())

    def scenario_record(self) -> ScenarioAnnounce:
        sim = self.sim
        info = {"id": sim.scenario.id, "params": self.params, "seed": self.seed,
                "trial": sim.data.trial.to_dict() if sim.data.trial else None, "tick": sim.data.tick}
        if self.switch:  # every switch up to this one is settled (installed, superseded or failed)
            info["switch"] = self.switch
        return ScenarioAnnounce(info)

    def announce(self) -> list[Record]:
        """The records a hub needs to know what runs: the scene, then the scenario."""
        scene = self.sim.scene
        return [SceneAnnounce(scene.to_dict(), scene.hash), self.scenario_record()]

    # -- the parts of a tick -----------------------------------------------------------------------
    def step(self, now_ns: int) -> tuple[TickResult, State | None]:
        """One simulation step; returns the result and the state record to publish, if one is due."""
        result = self.sim.step()
        if self.record_every and result.tick % self.record_every == 0:
            self._record_trajectory(result)
        slot = int(result.tick * self.state_hz // self.sim.tick_hz)
        # Moving objects do not force a frame: a plane sliding under the HIP moves every tick.
        due = slot != self._publish_slot or result.cues_changed
        if not due:
            return result, None
        self._publish_slot = slot
        return result, self._state_record(result, now_ns)

    def device_cues(self, result: TickResult) -> list[dict] | None:
        """The tick's cues (wire form) when they differ from what the devices were last given,
        else None. Compared with what was sent, not with the previous tick: a scenario switch
        starts a new simulation whose first tick may look unchanged while the devices still show
        the old scenario's cue; after a (re)start the first tick always sends. These are the
        primary tool's; the other tools' go with them in `finger_cues` (TickOutput)."""
        output = result.output
        cues, tool_cues = output.cues, output.tool_cues
        if cues == self._device_cues and (tool_cues is self._device_tool_cues or tool_cues == self._device_tool_cues):
            self._out.finger_cues = None
            return None
        self._device_cues, self._device_tool_cues = cues, tool_cues
        self._out.finger_cues = finger_cues(output, self.sim.data.tools) if len(self.sim.data.tools) > 1 else None
        return self.view.wire_cues(cues)

    def resend_device_cues(self) -> None:
        """The last cues could not be handed over: the next tick sends its cues whatever they are."""
        self._device_cues = self._device_tool_cues = None

    def fail_safe_cues(self) -> list | None:
        """A failed tick: every actuator off ([], and no finger's cues), unless the devices are
        off already (None)."""
        self._out.finger_cues = None
        if self._device_cues == () and not self._device_tool_cues:
            return None
        self._device_cues, self._device_tool_cues = (), NO_TOOL_CUES
        return []

    def _record_trajectory(self, r: TickResult) -> None:
        held = r.output.held
        sim = self.sim
        pose = sim.data.moved.get(held) if held else None
        self.trajectory.append([r.tick, *_round(r.hip), *_round(r.proxy), int(r.contact), held,
                                *(_round(pose.pos) if pose else (None, None, None))])
        if len(sim.data.tools) > 1 or sim.data.points:  # several points: every one, for replay (records.py POINT_ROW)
            points = {tool.name: _round(tool.tracked) for tool in sim.data.tools}
            for name, position in sim.data.points.items():
                points[name] = _round(position)
            self.point_rows.append([r.tick, points])

    def unsent(self, state: State) -> None:
        """The driver could not hand `state` over (the hub's end of the mailbox is full): what it
        alone carries (trajectory rows, events, trial ends, applied tracker samples, timing
        samples) goes out with the next state record instead of being lost."""
        self.states_unsent += 1
        recorded = state.recorded
        self.trajectory[:0] = recorded.trajectory
        self.point_rows[:0] = recorded.point_rows
        self.tracker_applied[:0] = recorded.trackers
        sim = self.sim
        sim.data.events[:0] = state.view["events"]
        sim.data.finished[:0] = recorded.finished
        samples = array("q")
        samples.frombytes(state.timing.samples)
        samples.extend(self.samples)
        self.samples = samples[-len(TIMING_SAMPLE) * MAX_CARRIED_TIMING:]  # timing is telemetry: the newest suffice

    def record_sample(self, period_ns: int, cost_ns: int, published: bool = False) -> None:
        """One tick's timing (records.py TIMING_SAMPLE); `published`: it built a state record."""
        samples = self.samples
        samples.append(period_ns)
        samples.append(cost_ns)
        samples.append(1 if published else 0)

    def _state_record(self, r: TickResult, now_ns: int) -> State:
        """The state record (server/ipc/records.py State): the view clients see (state_view.py),
        then what it alone carries (trajectory rows, events, trial ends, applied tracker samples,
        timing), which goes out with it once: those buffers start anew."""
        self.frames += 1
        sim = self.sim
        view = (self.view.drawn if self.drawn else self.view.undrawn)(r, sim, self.frames, now_ns)
        state = State(view, Recorded(self.trajectory, self.tracker_applied, sim.data.finished, self.point_rows),
                      Timing(self.samples.tobytes(), self.failures, self.resyncs))
        self.samples = array("q")
        self.tracker_applied = []
        self.trajectory = []
        self.point_rows = []
        sim.data.events = []
        sim.data.finished = []
        return state
