"""LoopCore: what the 1 kHz loop does each tick, between the mailbox and the simulation.

Records in (tracker samples, keys, device reports) are applied between ticks; then one
simulation step; then, if a publish is due, one state record goes out. A state record is due on
the regular cadence (state_hz, 60 by default) AND in any tick whose cues changed: the hub hands
the cues of every such record to the device manager (serial I/O lives in the hub process, never
here), so the device command and the picture of the same tick leave together and a tactile cue
never leads the picture (haptic-before-visual is noticed from ~15 ms, Di Luca & Mahnan 2019).

Pure apart from the clock values it is handed: the process adapter (process.py) owns sockets,
priority and sleeping; tests drive this class directly on a virtual clock.
"""

from __future__ import annotations

from array import array
from typing import Any

from devices.cues import cue_to_wire
from server.loop.simulation import Simulation, TickResult


def _round(v, digits: int = 9) -> list[float]:
    return [round(v[0], digits), round(v[1], digits), round(v[2], digits)]


class LoopCore:
    def __init__(self, sim: Simulation, *, state_hz: float = 60.0):
        if not 0 < state_hz <= sim.tick_hz:
            raise ValueError("state_hz must be in (0, tick_hz]")
        self.sim = sim
        self.state_hz = state_hz
        self._publish_slot = -1      # index of the last cadence slot published
        self.samples = array("q")    # (period_ns, cost_ns) pairs since the last state record
        self.tracker_applied: list[list] = []  # [client_id, seq, t_ms, recv_ns, applied_ns]
        self.frames = 0

    def apply(self, record: list, now_ns: int) -> None:
        """Apply one mailbox record (between ticks)."""
        kind = record[0]
        if kind == "tracker":
            _, client_id, seq, t_ms, pos, _quat, recv_ns = record
            self.sim.set_hip((float(pos[0]), float(pos[1]), float(pos[2])))
            self.tracker_applied.append([client_id, seq, t_ms, recv_ns, now_ns])
        elif kind == "input":
            _, _client_id, key, action = record
            self.sim.input(key, action)
        elif kind == "devices":  # the device manager's refusals, for the scenario (TickContext.refusals)
            self.sim.refusals = tuple(str(text) for text in record[1].get("refusals", ()))

    def step(self, now_ns: int) -> tuple[TickResult, dict | None]:
        """One tick; returns the result and the state record to publish, if one is due."""
        result = self.sim.step()
        slot = int(result.tick * self.state_hz // self.sim.tick_hz)
        due = slot != self._publish_slot or result.cues_changed or result.poses_changed
        if not due:
            return result, None
        self._publish_slot = slot
        return result, self._state_record(result, now_ns)

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
            "cues": [cue_to_wire(c) for c in out.cues], "hud": out.hud, "values": out.values,
            "samples": self.samples.tobytes(),
            "trackers": self.tracker_applied,
        }
        self.samples = array("q")
        self.tracker_applied = []
        return record
