"""The health rule for tracking: a tracker that stopped is a reason for `degraded` (docs/trackers.md
"Tracker loss is safe", docs/protocol.md `health`).

Sans-I/O, fed by the hub with what it learns, on one monotonic clock (seconds):
- `sources(...)`: each configured tracker source's health as the tracker host reports it (every
  0.1 s; `GET /api/trackers` `sources`): `status` `lost` means no sample for longer than its ttl;
- `loop(...)`: the loop's state record: `tracking.lost` (sources whose samples outlived their
  ttl, each a client id: `udp:HOST:PORT` for the tracker host's sources and bridges, an int for a
  /ws client) and the tools it left released (`tools[].lost`).

Reason `tracker_lost`, one per lost source: a configured source the tracker host reports lost
(whether or not it drove a tool yet: a tracker the experimenter configured does not track), or a
source the loop lists lost while one of its tools is released (a bridge, a WebXR client). A
configured source and the loop's entry for the same source (the host's `client_id`) are one
reason. A replay that ran `once` and finished is not a fault: a note (`tracker_finished`).
"""

from __future__ import annotations

from typing import Mapping, Sequence

TRACKER_CODES = ("tracker_lost",)
FINISHED_NOTE = "replay finished"  # the tracker host's note for a replay that ran once to its end


class TrackingWatch:
    def __init__(self) -> None:
        self._sources: dict[str, dict] = {}  # name → the tracker host's latest health entry
        self._source_since: dict[str, float] = {}  # name → when it was first seen lost (this time)
        self._lost: tuple = ()  # the loop's tracking.lost
        self._lost_tools: tuple[str, ...] = ()
        self._lost_since: dict = {}  # loop source → when it was first listed lost (this time)

    # ---- inputs ----------------------------------------------------------------------------
    def sources(self, entries: Sequence[Mapping], now_s: float) -> bool:
        """The tracker host's per-source health; True when a source's status or note changed."""
        changed = False
        for entry in entries:
            name = entry["name"]
            old = self._sources.get(name)
            if old is None or (old.get("status"), old.get("note")) != (entry.get("status"), entry.get("note")):
                changed = True
            if entry.get("status") == "lost":
                self._source_since.setdefault(name, now_s)
            else:
                self._source_since.pop(name, None)
            self._sources[name] = dict(entry)
        return changed

    def loop(self, lost: Sequence, lost_tools: Sequence[str], now_s: float) -> bool:
        """The loop's `tracking.lost` and the names of its released tools; True when changed."""
        lost, lost_tools = tuple(lost), tuple(lost_tools)
        if (lost, lost_tools) == (self._lost, self._lost_tools):
            return False
        self._lost_since = {s: self._lost_since.get(s, now_s) for s in lost}
        self._lost, self._lost_tools = lost, lost_tools
        return True

    # ---- the verdict -----------------------------------------------------------------------
    def evaluate(self, now_s: float) -> tuple[list[dict], list[dict]]:
        """(reasons, notes) for health's report."""
        reasons: list[dict] = []
        notes: list[dict] = []
        tools = ", ".join(self._lost_tools)
        released = (f"; finger{'s' if len(self._lost_tools) > 1 else ''} {tools} released (home, no contact "
                    "cue) until it sends again") if self._lost_tools else ""
        by_client = {e.get("client_id"): name for name, e in self._sources.items() if e.get("client_id")}
        for name, entry in self._sources.items():
            if entry.get("status") != "lost":
                continue
            since = self._source_since.get(name, now_s)
            mine = entry.get("client_id") in self._lost
            if mine:
                since = min(since, self._lost_since[entry["client_id"]])
            if entry.get("note") == FINISHED_NOTE:
                notes.append(_item("tracker_finished", since, now_s, f"tracker source '{name}' ({entry.get('target')}) "
                                   "finished its replay (it ran once)"))
                continue
            why = "; ".join(entry.get("reasons") or ()) or "no samples"
            note = entry.get("note")
            reasons.append(_item("tracker_lost", since, now_s, f"tracker source '{name}' ({_what(entry)}) is lost: "
                                 f"{why}{f' ({note})' if note else ''}{released if mine else ''}. "
                                 f"{_advice(entry.get('kind'))}"))
        if self._lost_tools:
            for source in self._lost:
                name = by_client.get(source)
                if name is not None and self._sources[name].get("status") == "lost":
                    continue  # told above, under its name
                who = (f"'{name}' ({_what(self._sources[name])})" if name is not None
                       else f"client {source}" if isinstance(source, int) else f"'{source}'")
                reasons.append(_item("tracker_lost", self._lost_since.get(source, now_s), now_s,
                                     f"tracker source {who} stopped sending (its samples' ttl passed){released}. "
                                     + (_advice(self._sources[name].get("kind")) if name is not None
                                        else "Check the tracker, its bridge or the participant's browser")))
        return reasons, notes


def _item(code: str, since: float, now_s: float, message: str) -> dict:
    return {"code": code, "message": message, "since_s": round(max(0.0, now_s - since), 3)}


def _what(entry: Mapping) -> str:
    kind, target = entry.get("kind", "?"), entry.get("target")
    return f"{kind}, {target}" if target else str(kind)


def _advice(kind) -> str:
    if kind == "leap":
        return "Check that the Leap Motion service runs and the hand is in the tracker's view"
    if kind == "replay":
        return "Check the replay file (the server log says why it stopped)"
    return "The server log says why it stopped"
