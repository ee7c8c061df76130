"""What clients see of a tick: the view of a state record (server/ipc/records.py State.view).

Built only when a state record is due (60 Hz and at cue changes), never per tick. Between tracker
samples the HIP, proxy, force, contacts and object poses are the very objects of the last record,
so their rounded forms are kept and shared instead of rounded again (round() is ~0.25 µs a
number); nothing downstream changes a record's lists. Each kept form sits beside the object it
was rounded from (`_Kept`): rounded again only when that object changed.
"""

from __future__ import annotations

from typing import Any, Mapping

from server.core.cues import cue_to_wire


def rounded(v, digits: int = 9) -> list[float]:
    return [round(v[0], digits), round(v[1], digits), round(v[2], digits)]


class _Kept:
    """The last source object and its rounded form."""

    __slots__ = ("source", "form")

    def __init__(self) -> None:
        self.source: Any = None
        self.form: Any = None


class StateView:
    def __init__(self) -> None:
        self.hip, self.proxy, self.force, self.contacts = _Kept(), _Kept(), _Kept(), _Kept()
        self.cues = _Kept()  # the last cue tuple and its wire form (also the device command's)
        self.quat = _Kept()  # the last quat of an object row
        self.object_rows: dict[str, tuple] = {}  # object id → (pose, its row)
        self.tool_rows: dict[str, tuple] = {}  # another tool's name → (hip, rounded, proxy, rounded)

    def drawn(self, r, sim, frame: int, now_ns: int) -> dict[str, Any]:
        """The wire's state fields (docs/protocol.md) in their order, without `type` and
        `telemetry` (the hub adds them)."""
        out = r.output
        tool = sim.data.tools[0]
        kept = self.hip  # inline, not a helper call each: this runs at every publish
        if kept.source is not r.hip:
            kept.source, kept.form = r.hip, rounded(r.hip)
        hip = kept.form
        kept = self.proxy
        if kept.source is not r.proxy:
            kept.source, kept.form = r.proxy, rounded(r.proxy)
        proxy = kept.form
        kept = self.force
        if kept.source is not r.force:
            kept.source, kept.form = r.force, rounded(r.force, 6)
        force = kept.form
        contacts = self.contacts
        if contacts.source is not r.contacts:
            contacts.source = r.contacts
            contacts.form = [[c.body_id, rounded(c.normal, 6), round(c.depth, 9)] for c in r.contacts]
        # the primary tool's entry shares the rounded hip and proxy above (r.tools[0] is that tool)
        tools = [{"name": tool.name, "hip": hip, "proxy": proxy, "contact": r.contact, "lost": r.tools[0].lost}]
        if len(r.tools) > 1:
            kept_rows = self.tool_rows
            for v in r.tools[1:]:
                kept = kept_rows.get(v.name)
                if kept is None or kept[0] is not v.hip or kept[2] is not v.proxy:
                    kept = kept_rows[v.name] = (v.hip, rounded(v.hip), v.proxy, rounded(v.proxy))
                tools.append({"name": v.name, "hip": kept[1], "proxy": kept[3], "contact": v.contact, "lost": v.lost})
        return {
            "frame": frame, "tick": r.tick, "t": now_ns / 1e9, "scene": sim.scene.hash,
            "hip": hip, "proxy": proxy, "force": force,
            "contact": r.contact,
            "contacts": contacts.form,
            "objects": self._objects(sim.data.moved) if sim.data.moved else [],
            "cues": self.wire_cues(out.cues), "hud": out.hud, "values": out.values,
            "visible": dict(sim.data.visibility),
            "events": sim.data.events,
            "scales": {oid: list(s) for oid, s in sim.data.scales.items()} if sim.data.scales else {},
            "stiffness": r.stiffness,  # never changed in place (Simulation): no copy needed
            "haptic": r.touch_overrides,  # the wire keeps its name
            "driver": None if tool.driver is None else [tool.driver, tool.seq],
            "tools": tools,
            "points": {name: rounded(p) for name, p in sim.data.points.items()} if sim.data.points else {},
            "tracking": {"lost": list(sim.data.lost_sources) if sim.data.lost_sources else []},
        }

    def undrawn(self, r, sim, frame: int, now_ns: int) -> dict[str, Any]:
        """A run nobody draws (the simulated study): what the recorder and a synthetic
        participant read, none of the picture."""
        return {"frame": frame, "tick": r.tick, "t": now_ns / 1e9, "scene": sim.scene.hash,
                "cues": self.wire_cues(r.output.cues), "hud": r.output.hud, "events": sim.data.events}

    def _objects(self, moved: Mapping[str, Any]) -> list[list]:
        """`objects` of the state: [id, pos, quat] of each moved object, rounded once per pose."""
        memo = self.object_rows
        rows = []
        for oid, pose in moved.items():
            kept = memo.get(oid)
            if kept is None or kept[0] is not pose:
                quat = pose.quat  # a moving object keeps its quat tuple (often the shared no-rotation one)
                if self.quat.source is not quat:
                    self.quat.source, self.quat.form = quat, [round(q, 9) for q in quat]
                kept = memo[oid] = (pose, [oid, rounded(pose.pos), self.quat.form])
            rows.append(kept[1])
        return rows

    def wire_cues(self, cues: tuple) -> list[dict]:
        """The wire form of a cue tuple (a fresh list); converted once while the scenario keeps
        handing back the same tuple. The device command and the state record share the maps."""
        kept = self.cues
        if kept.source is not cues:
            kept.source, kept.form = cues, [cue_to_wire(c) for c in cues]
        return list(kept.form)
