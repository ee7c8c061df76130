"""One source's samples → tracker datagrams (the wire format of docs/protocol.md, v1.4 fields).

For each sample (raw points in the source's frame, its time, its confidence): calibrate every
point into the scene frame, filter each point with its own 1€ filter, and build the `tracker`
message: `pos` is the primary point (`right.index.tip`, or the first finger tip the sample has
when the hand holds no right index), `point` names it, `points` carries the others, `ttl` says
how long the sample is good for (the loop releases the source's tools when nothing newer came).
Points outside the workspace are dropped (the wire would refuse the whole sample); a sample
whose `pos` is outside is not sent at all (counted).

`ttl = clamp(4 × nominal period, 20 ms, 60 ms)`: a streaming source that stops is out of
contact within ttl + one tick, well inside 100 ms.

Pure: dicts in, dicts out; the tracker host encodes and sends them.
"""

from __future__ import annotations

from server.core.points import PRIMARY_POINT
from server.core.workspace import in_workspace
from server.tracking.calibration import Calibration
from server.tracking.one_euro import DEFAULT_PARAMS, OneEuro3, OneEuroParams

TTL_MIN_MS = 20.0
TTL_MAX_MS = 60.0


def ttl_ms(nominal_hz: float) -> float:
    return min(max(4000.0 / nominal_hz, TTL_MIN_MS), TTL_MAX_MS)


class SourcePipeline:
    def __init__(self, name: str, calibration: Calibration, *, nominal_hz: float,
                 filter_params: OneEuroParams | None = DEFAULT_PARAMS, primary: str = PRIMARY_POINT):
        self.name = name
        self.calibration = calibration
        self.filter_params = filter_params  # None: no filtering (a scripted source is exact)
        self.primary = primary
        self.ttl = ttl_ms(nominal_hz)
        self.seq = 0
        self.outside = 0  # samples not sent: their primary point left the workspace
        self.last_raw: dict = {}
        self.last_scene: dict = {}
        self._filters: dict[str, OneEuro3] = {}

    def set_calibration(self, calibration: Calibration) -> None:
        self.calibration = calibration
        self.reset_filters()  # a jump in the scene frame is not a movement

    def reset_filters(self) -> None:
        self._filters.clear()

    def _filtered(self, name: str, p, t_s: float):
        if self.filter_params is None:
            return p
        f = self._filters.get(name)
        if f is None:
            f = self._filters[name] = OneEuro3(self.filter_params)
        return f(p, t_s)

    def process(self, raw_points: dict, t_s: float, *, stamp_ms: float | None = None) -> dict | None:
        """The datagram's map for one sample at `t_s` (seconds, the source's clock: what the
        filters see); `stamp_ms` is the message's `t` (default t_s in ms). None when the sample
        has no usable point."""
        self.last_raw = dict(raw_points)
        scene = {}
        for name, p in raw_points.items():
            q = self._filtered(name, self.calibration.apply(p), t_s)
            if in_workspace(q):
                scene[name] = q
        self.last_scene = scene
        pos_name = self.primary if self.primary in scene else next(
            (n for n in sorted(scene) if n.endswith(".index.tip")), next(iter(sorted(scene)), None))
        if pos_name is None:
            if raw_points:
                self.outside += 1
            return None
        self.seq += 1
        message = {"type": "tracker", "seq": self.seq, "t": round(t_s * 1000.0 if stamp_ms is None else stamp_ms, 3), "pos": list(scene[pos_name]),
                   "point": pos_name, "ttl": self.ttl}
        others = {n: list(p) for n, p in scene.items() if n != pos_name}
        if others:
            message["points"] = others
        return message
