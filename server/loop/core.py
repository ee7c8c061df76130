"""LoopCore: the whole tick of the 1 kHz loop, as data in and data out.

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
reported as `["fault", {"failures", "tick", "error"}]` at the first failure of a streak and at most
every FAULT_REPORT_EVERY ticks while it lasts, then `["recovered", {"tick", "failures"}]` at the
first good tick; both come out in `TickOutput.faults` (the hub reads them for health).

A scenario switch is built outside the tick. Building one takes milliseconds (a scene of many
bodies: 8-17 ms for the positioning tasks), more than a tick's period, so with `build_off_tick`
(the loop process) `apply(["scenario", ...])` only checks the name and records the switch as
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
source drives the HIP; `["tracker_gone", client_id]` sends it home when its driver leaves.
"""

from __future__ import annotations

import traceback
from array import array
from dataclasses import dataclass
from typing import Any, Callable, Mapping

from server.core.cues import cue_to_wire
from server.core.records import TIMING_SAMPLE
from scenarios import registry
from server.core.scenario import NO_TOOL_CUES, Trial
from server.loop.cadence import STATE_HZ
from server.loop.simulation import Simulation, TickResult

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


def _round(v, digits: int = 9) -> list[float]:
    return [round(v[0], digits), round(v[1], digits), round(v[2], digits)]


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
        self.records: list[list] | tuple = ()  # for the hub, in order, before the state record
        # `fault` / `recovered` records for the hub's health, sent after `records`, before the state
        self.faults: list[list] | tuple = ()
        self.state: dict | None = None  # the state record, when one is due
        self.error: str | None = None  # why the step failed (also in `records` as a log line)


class LoopCore:
    def __init__(self, sim: Simulation, *, state_hz: float = STATE_HZ,
                 make_sim: Callable[..., Simulation] | None = None, build_off_tick: bool = False,
                 drawn: bool = True):
        if not 0 < state_hz <= sim.tick_hz:
            raise ValueError("state_hz must be in (0, tick_hz]")
        # False: no client draws this run's state (the simulated study's virtual hub): a state
        # record carries only what the hub's recorder and a synthetic participant read (_state_record).
        self.drawn = drawn
        sim.drawn = drawn
        self.sim = sim
        self.make_sim = make_sim or (lambda scenario, seed: Simulation(scenario, tick_hz=sim.tick_hz, seed=seed,
                                                                       rig=sim.rig))
        self.params: dict = {}
        self.seed = 0
        self.outbox: list[list] = []  # records for the hub besides state (scene and scenario changes, logs)
        self.state_hz = state_hz
        self._publish_slot = -1      # index of the last cadence slot published
        self.samples = array("q")    # TIMING_SAMPLE rows since the last state record (records.py)
        self.tracker_applied: list[list] = []  # [client_id, seq, t_ms, recv_ns, applied_ns]
        self.states_unsent = 0       # state records the driver could not send; their contents went out later
        self.frames = 0
        self.failures = 0            # ticks that failed since start
        self._failing = False        # the last tick failed (a `recovered` record follows the next good one)
        self._fault_reported_tick = 0
        self._faults: list[list] = []  # this tick's `fault` / `recovered` records (TickOutput.faults)
        self.record_every = 0        # trajectory sampling: every Nth tick while an experiment records; 0 = off
        self.trajectory: list[list] = []  # rows since the last state record (server/core/records.py TRAJECTORY_COLUMNS)
        self.point_rows: list[list] = []  # [tick, {point: [x, y, z]}] with them, when several points are tracked
        self._device_cues: tuple | None = None  # what the devices were last given; None: unknown (start)
        self._device_tool_cues: Mapping | None = None  # and the other tools' devices (ScenarioOutput.tool_cues)
        self._out = TickOutput()
        # The last rounded hip, proxy, force and contacts of a state record, as (source, rounded)
        # pairs; the rows of moved objects; the last wire cues (see _state_record, wire_cues).
        self._rounded: list = [None] * 8
        self._object_rows: dict[str, tuple] = {}
        self._quat: tuple = (None, None)  # the last quat rounded for an object row, and its row form
        self._tool_rounded: dict[str, tuple] = {}
        self._wire: list = [None, []]
        self.build_off_tick = build_off_tick  # True: the driver builds a switch off the tick (module doc)
        self.pending_switch: Switch | None = None  # asked, not yet installed
        self.switch = 0  # the number of the last switch installed or abandoned (the hub matches its own by it)
        self._waiting: list[list] = []  # trial records for the pending switch's scenario

    # -- the tick --------------------------------------------------------------------------------
    def tick(self, records, now_ns: int) -> TickOutput:
        """Apply `records` (a bad one is reported, never fatal), step once, and say what goes out."""
        for record in records:
            try:
                self.apply(record, now_ns)
            except Exception:  # noqa: BLE001 - a bad switch or trial must not kill the loop
                self.outbox.append(["log", "error", f"record {record[0]} failed: {traceback.format_exc()}"])
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
                self._faults.append(["recovered", {"tick": tick, "failures": self.failures}])
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
        if sim.cues:
            sim.cues = ()
            self.outbox.append(["fail_safe"])
        for tool in sim.tools:
            tool.reset_proxy()
        sim.tick = tick + 1
        error = self._out.error = traceback.format_exc()
        if not self._failing or tick - self._fault_reported_tick >= FAULT_REPORT_EVERY:
            self._fault_reported_tick = tick
            self._faults.append(["fault", {"failures": self.failures, "tick": tick,
                                          "error": f"{type(exc).__name__}: {exc}"[:MAX_FAULT_TEXT]}])
        self._failing = True
        if self.failures <= MAX_REPORTED_FAILURES or self.failures % 1000 == 0:
            self.outbox.append(["log", "error", f"tick failed ({self.failures}): {error}"])
        return cues

    # -- records in (between ticks) --------------------------------------------------------------
    def apply(self, record: list, now_ns: int) -> None:
        """Apply one record from the hub (between ticks)."""
        kind = record[0]
        if kind == "tracker":  # ["tracker", client_id, seq, t_ms, pos, quat, recv_ns, (point, points, ttl_ms)]
            client_id, seq, pos = record[1], record[2], record[4]
            sim = self.sim
            if len(record) > 7:  # protocol v1.4: the point pos is, more points, ttl (tracker_udp.py)
                point, points, ttl_ms = record[7], record[8], record[9]
                if points:
                    points = {name: (float(p[0]), float(p[1]), float(p[2])) for name, p in points.items()}
            else:
                point = points = ttl_ms = None
            if sim.offer(client_id, seq, (float(pos[0]), float(pos[1]), float(pos[2])), point, points, ttl_ms):
                self.tracker_applied.append([client_id, seq, record[3], record[6], now_ns])
            else:
                tool = sim.tool_by_name.get(point or sim.tools[0].name, sim.tools[0])
                ignored = tool.ignored.get(client_id, 0)
                if ignored == 1 or ignored % IGNORED_NOTICE_EVERY == 0:
                    what = "the HIP" if tool is sim.tools[0] else tool.name
                    self.outbox.append(["log", "warning", f"tracker samples from {client_id} ignored: {tool.driver} "
                                                          f"drives {what} ({ignored} ignored so far)"])
        elif kind == "tracker_gone":  # ["tracker_gone", client_id]: a source left; the tools it drove go home
            self.sim.release(record[1])
        elif kind == "input":  # ["input", client_id, key, action, value?]; checked by the hub
            value = record[4] if len(record) > 4 else None
            self.sim.input(record[2], record[3], value)
            sim = self.sim  # every key and command is recorded with the tick it took effect
            sim.events.append({"tick": sim.tick, "t": sim.tick / sim.tick_hz, "name": "input", "client": record[1],
                               "key": record[2], "action": record[3], "value": value})
        elif kind == "trial":  # ["trial", {"phase", "params", "index"} | None]; checked by the hub
            if self.pending_switch is not None:  # for the scenario being built: applied when it is installed
                self._waiting.append(record)
                return
            body = record[1]
            trial = None if body is None else Trial.parse(type(self.sim.scenario).TRIAL_PARAMS, body.get("phase"),
                                                          body.get("params"), body.get("index", 0))
            self.sim.set_trial(trial)
            self.outbox.append(self.scenario_record())
        elif kind == "scenario":  # ["scenario", name, params, seed, number?]: switch between trials (module doc)
            _, name, params, seed, *numbered = record
            registry.resolve(name)  # an unknown name is reported now, not after a build
            self.ask_switch(Switch(name, dict(params), seed, numbered[0] if numbered else 0))
        elif kind == "record":  # ["record", every_n_ticks]: trajectory rows ride with the state records
            self.record_every = max(0, int(record[1]))
            self.trajectory = []
            self.point_rows = []
        elif kind == "devices":  # the device manager's refusals, for the scenario (TickContext.refusals)
            self.sim.refusals = tuple(str(text) for text in record[1].get("refusals", ()))

    # -- scenario switches (module doc) -------------------------------------------------------------
    def ask_switch(self, switch: Switch) -> None:
        """Record a switch; it supersedes one still pending (latest wins). Built here unless the
        driver builds off the tick."""
        if self.pending_switch is not None:
            self._waiting.clear()  # trials for the superseded scenario
            self.outbox.append(["log", "warning", f"scenario switch to {self.pending_switch.name} superseded by "
                                                  f"{switch.name} before it was built"])
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
                self.outbox.append(["log", "error", f"record {record[0]} failed: {traceback.format_exc()}"])
        return True

    def abandon(self, switch: Switch, error: str) -> None:
        """A switch whose build failed: reported; the running scenario goes on."""
        self.outbox.append(["log", "error", f"record scenario failed: {error}"])
        if switch is self.pending_switch:
            self.pending_switch = None
            if self._waiting:
                self.outbox.append(["log", "error", f"{len(self._waiting)} trial record(s) for {switch.name} dropped: "
                                                    "its scenario could not be built"])
                self._waiting = []
            # the hub counts this switch as in flight until it hears of it: say what runs instead
            self.switch = switch.number
            record = self.scenario_record()
            record[1]["failed"] = switch.name
            self.outbox.append(record)

    def _take_over(self, sim: Simulation, params: dict, seed: int) -> None:
        """`sim` replaces the running simulation; announces the new scene."""
        sim.data.carry_over(self.sim.data)  # the tick, unpublished events, who drives what (SimData)
        sim.drawn = self.drawn
        self.sim, self.params, self.seed = sim, dict(params), seed
        self.outbox.extend(self.announce())

    def scenario_record(self) -> list:
        sim = self.sim
        info = {"id": sim.scenario.id, "params": self.params, "seed": self.seed,
                "trial": sim.trial.to_dict() if sim.trial else None, "tick": sim.tick}
        if self.switch:  # every switch up to this one is settled (installed, superseded or failed)
            info["switch"] = self.switch
        return ["scenario", info]

    def announce(self) -> list[list]:
        """The records a hub needs to know what runs: the scene, then the scenario."""
        scene = self.sim.scene
        return [["scene", scene.to_dict(), scene.hash], self.scenario_record()]

    # -- the parts of a tick -----------------------------------------------------------------------
    def step(self, now_ns: int) -> tuple[TickResult, dict | None]:
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
        self._out.finger_cues = finger_cues(output, self.sim.tools) if len(self.sim.tools) > 1 else None
        return self.wire_cues(cues)

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
        pose = sim.moved.get(held) if held else None
        self.trajectory.append([r.tick, *_round(r.hip), *_round(r.proxy), int(r.contact), held,
                                *(_round(pose.pos) if pose else (None, None, None))])
        if len(sim.tools) > 1 or sim.points:  # several points: every one, for replay (records.py POINT_ROW)
            points = {tool.name: _round(tool.tracked) for tool in sim.tools}
            for name, position in sim.points.items():
                points[name] = _round(position)
            self.point_rows.append([r.tick, points])

    def unsent(self, state: dict) -> None:
        """The driver could not hand `state` over (the hub's end of the mailbox is full): what it
        alone carries (trajectory rows, events, trial ends, applied tracker samples, timing
        samples) goes out with the next state record instead of being lost."""
        self.states_unsent += 1
        self.trajectory[:0] = state["trajectory"]
        self.point_rows[:0] = state.get("point_rows", ())
        self.tracker_applied[:0] = state["trackers"]
        sim = self.sim
        sim.events[:0] = state["events"]
        sim.finished[:0] = state["finished"]
        samples = array("q")
        samples.frombytes(state["samples"])
        samples.extend(self.samples)
        self.samples = samples[-len(TIMING_SAMPLE) * MAX_CARRIED_TIMING:]  # timing is telemetry: the newest suffice

    def record_sample(self, period_ns: int, cost_ns: int, published: bool = False) -> None:
        """One tick's timing (records.py TIMING_SAMPLE); `published`: it built a state record."""
        samples = self.samples
        samples.append(period_ns)
        samples.append(cost_ns)
        samples.append(1 if published else 0)

    def _state_record(self, r: TickResult, now_ns: int) -> dict[str, Any]:
        """The state record: the wire's state fields (docs/protocol.md) in their order, without
        `type` and `telemetry` (the hub adds them), then what only the hub and recorder use.

        Built only when one is due (60 Hz and at cue changes), never per tick. Between tracker
        samples the HIP, proxy, contacts and object poses are the very objects of the last record,
        so their rounded forms are kept and shared instead of rounded again (round() is ~0.25 µs a
        number); nothing downstream changes a record's lists."""
        self.frames += 1
        out = r.output
        sim = self.sim
        if not self.drawn:
            return self._recorded_state(r, now_ns)
        tool = sim.tools[0]
        memo = self._rounded
        if memo[0] is not r.hip:
            memo[0], memo[1] = r.hip, _round(r.hip)
        if memo[2] is not r.proxy:
            memo[2], memo[3] = r.proxy, _round(r.proxy)
        if memo[4] is not r.force:
            memo[4], memo[5] = r.force, _round(r.force, 6)
        if memo[6] is not r.contacts:
            memo[6], memo[7] = r.contacts, [[c.body_id, _round(c.normal, 6), round(c.depth, 9)] for c in r.contacts]
        hip, proxy = memo[1], memo[3]
        # the primary tool's entry shares the rounded hip and proxy above (r.tools[0] is that tool)
        tools = [{"name": tool.name, "hip": hip, "proxy": proxy, "contact": r.contact, "lost": r.tools[0].lost}]
        if len(r.tools) > 1:
            rounded = self._tool_rounded  # per other tool: (hip, rounded, proxy, rounded), as above
            for v in r.tools[1:]:
                kept = rounded.get(v.name)
                if kept is None or kept[0] is not v.hip or kept[2] is not v.proxy:
                    kept = rounded[v.name] = (v.hip, _round(v.hip), v.proxy, _round(v.proxy))
                tools.append({"name": v.name, "hip": kept[1], "proxy": kept[3], "contact": v.contact, "lost": v.lost})
        record = {
            "frame": self.frames, "tick": r.tick, "t": now_ns / 1e9, "scene": sim.scene.hash,
            "hip": hip, "proxy": proxy, "force": memo[5],
            "contact": r.contact,
            "contacts": memo[7],
            "objects": self._objects(sim.moved) if sim.moved else [],
            "cues": self.wire_cues(out.cues), "hud": out.hud, "values": out.values,
            "visible": dict(sim.visibility),
            "events": sim.events,
            "scales": {oid: list(s) for oid, s in sim.scales.items()} if sim.scales else {},
            "stiffness": r.stiffness,  # never changed in place (Simulation): no copy needed
            "haptic": r.haptic,
            "driver": None if tool.driver is None else [tool.driver, tool.seq],
            "tools": tools,
            "points": {name: _round(p) for name, p in sim.points.items()} if sim.points else {},
            "tracking": {"lost": list(sim.lost_sources) if sim.lost_sources else []},
            "samples": self.samples.tobytes(),
            "trackers": self.tracker_applied,
            "trajectory": self.trajectory,
            "finished": sim.finished,
        }
        return self._hand_over(record)

    def _recorded_state(self, r: TickResult, now_ns: int) -> dict[str, Any]:
        """The state record of a run nobody draws (`drawn` False): what the recorder
        (server/experiment/recorder.py) and a synthetic participant read, none of the picture."""
        sim = self.sim
        record = {"frame": self.frames, "tick": r.tick, "t": now_ns / 1e9, "scene": sim.scene.hash,
                  "cues": self.wire_cues(r.output.cues), "hud": r.output.hud, "events": sim.events,
                  "samples": self.samples.tobytes(), "trackers": self.tracker_applied,
                  "trajectory": self.trajectory, "finished": sim.finished}
        return self._hand_over(record)

    def _hand_over(self, record: dict[str, Any]) -> dict[str, Any]:
        """The end of a state record: what it alone carries (rows, events, trial ends, applied
        tracker samples, timing) goes out with it once; those buffers start anew."""
        if self.point_rows:  # several tracked points recorded (records.py POINT_ROW); absent: none
            record["point_rows"] = self.point_rows
            self.point_rows = []
        if self.failures:  # ticks failed since the loop started; absent means 0
            record["failures"] = self.failures
        self.samples = array("q")
        self.tracker_applied = []
        self.trajectory = []
        sim = self.sim
        sim.events = []
        sim.finished = []
        return record

    def _objects(self, moved: Mapping[str, Any]) -> list[list]:
        """`objects` of the state: [id, pos, quat] of each moved object, rounded once per pose."""
        memo = self._object_rows
        rows = []
        for oid, pose in moved.items():
            kept = memo.get(oid)
            if kept is None or kept[0] is not pose:
                quat = pose.quat  # a moving object keeps its quat tuple (often the shared no-rotation one)
                if self._quat[0] is not quat:
                    self._quat = (quat, [round(q, 9) for q in quat])
                kept = memo[oid] = (pose, [oid, _round(pose.pos), self._quat[1]])
            rows.append(kept[1])
        return rows

    def wire_cues(self, cues: tuple) -> list[dict]:
        """The wire form of a cue tuple (a fresh list); converted once while the scenario keeps
        handing back the same tuple. The device command and the state record share the maps."""
        memo = self._wire
        if memo[0] is not cues:
            memo[0], memo[1] = cues, [cue_to_wire(c) for c in cues]
        return list(memo[1])
