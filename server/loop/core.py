"""LoopCore: what the 1 kHz loop does each tick, between the mailbox and the simulation.

Records in (tracker samples, keys and commands, trials, scenario switches, device reports) are
applied between ticks; then one simulation step; then, if a publish is due, one state record goes
out. Scenario events (key presses, taps) ride with the next state record, each stamped with its
tick, so none is lost between publishes. A state record is due on
the regular cadence (state_hz, 60 by default) AND in any tick whose cues changed, so the picture
of that tick leaves with its device command and a tactile cue never leads the picture
(haptic-before-visual is noticed from ~15 ms, Di Luca & Mahnan 2019). The device command itself
leaves first, on a channel of its own (`device_cues`): the process adapter sends it straight to
the device host process's feed thread, past the hub's event loop (serial I/O lives there, never
here).

Pure apart from the clock values it is handed: the process adapter (process.py) owns sockets,
priority and sleeping; tests drive this class directly on a virtual clock.
"""

from __future__ import annotations

from array import array
from typing import Any, Callable

from server.core.cues import cue_to_wire
from scenarios import registry
from server.core.scenario import Trial
from server.loop.simulation import Simulation, TickResult




def _round(v, digits: int = 9) -> list[float]:
    return [round(v[0], digits), round(v[1], digits), round(v[2], digits)]


class LoopCore:
    def __init__(self, sim: Simulation, *, state_hz: float = 60.0,
                 make_sim: Callable[..., Simulation] | None = None):
        if not 0 < state_hz <= sim.tick_hz:
            raise ValueError("state_hz must be in (0, tick_hz]")
        self.sim = sim
        self.make_sim = make_sim or (lambda scenario, seed: Simulation(scenario, tick_hz=sim.tick_hz, seed=seed))
        self.params: dict = {}
        self.seed = 0
        self.outbox: list[list] = []  # records for the hub besides state (scene and scenario changes)
        self.state_hz = state_hz
        self._publish_slot = -1      # index of the last cadence slot published
        self.samples = array("q")    # (period_ns, cost_ns) pairs since the last state record
        self.tracker_applied: list[list] = []  # [client_id, seq, t_ms, recv_ns, applied_ns]
        self.frames = 0
        self.record_every = 0        # trajectory sampling: every Nth tick while an experiment records; 0 = off
        self.trajectory: list[list] = []  # rows since the last state record (server/core/records.py TRAJECTORY_COLUMNS)
        self._device_cues: tuple | None = None  # what the devices were last given; None: unknown (start)

    def apply(self, record: list, now_ns: int) -> None:
        """Apply one mailbox record (between ticks)."""
        kind = record[0]
        if kind == "tracker":
            _, client_id, seq, t_ms, pos, _quat, recv_ns = record
            self.sim.set_hip((float(pos[0]), float(pos[1]), float(pos[2])))
            self.tracker_applied.append([client_id, seq, t_ms, recv_ns, now_ns])
        elif kind == "input":  # ["input", client_id, key, action, value?]; checked by the hub
            value = record[4] if len(record) > 4 else None
            self.sim.input(record[2], record[3], value)
            sim = self.sim  # every key and command is recorded with the tick it took effect
            sim.events.append({"tick": sim.tick, "t": sim.tick / sim.tick_hz, "name": "input", "client": record[1],
                               "key": record[2], "action": record[3], "value": value})
        elif kind == "trial":  # ["trial", {"phase", "params", "index"} | None]; checked by the hub
            body = record[1]
            trial = None if body is None else Trial.parse(type(self.sim.scenario).TRIAL_PARAMS, body.get("phase"),
                                                          body.get("params"), body.get("index", 0))
            self.sim.set_trial(trial)
            self.outbox.append(self.scenario_record())
        elif kind == "scenario":  # ["scenario", name, params, seed]: switch between trials
            _, name, params, seed = record
            self.load_scenario(name, params, seed)
        elif kind == "record":  # ["record", every_n_ticks]: trajectory rows ride with the state records
            self.record_every = max(0, int(record[1]))
            self.trajectory = []
        elif kind == "devices":  # the device manager's refusals, for the scenario (TickContext.refusals)
            self.sim.refusals = tuple(str(text) for text in record[1].get("refusals", ()))

    def load_scenario(self, name: str, params: dict, seed: int) -> None:
        """A new scenario and simulation (tick counter continues); announces the new scene."""
        refusals = self.sim.refusals
        sim = self.make_sim(registry.create(name, **params), seed)
        sim.tick = self.sim.tick
        sim.refusals = refusals
        sim.events = self.sim.events  # unpublished events of the old scenario still go out
        self.sim, self.params, self.seed = sim, dict(params), seed
        self.outbox.extend(self.announce())

    def scenario_record(self) -> list:
        sim = self.sim
        return ["scenario", {"id": sim.scenario.id, "params": self.params, "seed": self.seed,
                             "trial": sim.trial.to_dict() if sim.trial else None, "tick": sim.tick}]

    def announce(self) -> list[list]:
        """The records a hub needs to know what runs: the scene, then the scenario."""
        scene = self.sim.scene
        return [["scene", scene.to_dict(), scene.hash], self.scenario_record()]

    def step(self, now_ns: int) -> tuple[TickResult, dict | None]:
        """One tick; returns the result and the state record to publish, if one is due."""
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
        the old scenario's cue; after a (re)start the first tick always sends."""
        cues = result.output.cues
        if cues == self._device_cues:
            return None
        self._device_cues = cues
        return [cue_to_wire(c) for c in cues]

    def resend_device_cues(self) -> None:
        """The last cues could not be handed over: the next tick sends its cues whatever they are."""
        self._device_cues = None

    def fail_safe_cues(self) -> list | None:
        """A failed tick: every actuator off ([]), unless the devices are off already (None)."""
        if self._device_cues == ():
            return None
        self._device_cues = ()
        return []

    def _record_trajectory(self, r: TickResult) -> None:
        held = r.output.held
        pose = self.sim.moved.get(held) if held else None
        self.trajectory.append([r.tick, *_round(r.hip), *_round(r.proxy), int(r.contact), held,
                                *(_round(pose.pos) if pose else (None, None, None))])

    def record_sample(self, period_ns: int, cost_ns: int) -> None:
        self.samples.append(period_ns)
        self.samples.append(cost_ns)

    def _state_record(self, r: TickResult, now_ns: int) -> dict[str, Any]:
        self.frames += 1
        out = r.output
        record = {
            "frame": self.frames, "tick": r.tick, "t": now_ns / 1e9,
            "hip": _round(r.hip), "proxy": _round(r.proxy), "force": _round(r.force, 6),
            "contact": r.contact,
            "contacts": [[c.body_id, _round(c.normal, 6), round(c.depth, 9)] for c in r.contacts],
            "objects": [[oid, _round(p.pos), [round(q, 9) for q in p.quat]] for oid, p in self.sim.moved.items()],
            "visible": dict(self.sim.visibility),
            "scales": {oid: list(s) for oid, s in self.sim.scales.items()},
            "cues": [cue_to_wire(c) for c in out.cues], "hud": out.hud, "values": out.values,
            "events": self.sim.events,
            "samples": self.samples.tobytes(),
            "trackers": self.tracker_applied,
            "trajectory": self.trajectory,
        }
        self.samples = array("q")
        self.tracker_applied = []
        self.trajectory = []
        self.sim.events = []
        return record
