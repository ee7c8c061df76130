"""A recorded trajectory as a tracker source (`viestac serve --tracker replay:FILE.csv[:loop|:once]`).

Reads the two CSV formats of docs/data.md and `viestac render`: `t,x,y,z` (seconds, the primary
point, scene units) and the multi-point form, `t` then `NAME.x,NAME.y,NAME.z` per point (a column
name is split with rsplit(".", 1)), and an exported trial's trajectory file (`t_s`, `hip_x`..`hip_z`:
the HIP as the loop applied it). `ReplayCursor` says which rows are due at an elapsed time,
once or looping (a loop restarts after the last row plus one median period).

Pure: text in, rows out; the tracker host's task sleeps until each row is due.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass

from server.core.points import PRIMARY_POINT, check_point_name
from server.core.records import EXPORT_TRAJECTORY_AS_SAMPLES


@dataclass(frozen=True)
class ReplayTrack:
    times: tuple[float, ...]
    rows: tuple[dict, ...]  # point name → (x, y, z)

    @property
    def period_s(self) -> float:
        steps = sorted(b - a for a, b in zip(self.times, self.times[1:]) if b > a)
        return steps[len(steps) // 2] if steps else 1.0 / 120.0

    @property
    def duration_s(self) -> float:
        return self.times[-1] - self.times[0] if self.times else 0.0

    @property
    def point_names(self) -> tuple[str, ...]:
        return tuple(self.rows[0]) if self.rows else ()


def parse_csv(text: str, *, where: str = "replay") -> ReplayTrack:
    reader = csv.reader(io.StringIO(text))
    header = [h.strip() for h in next(reader, [])]
    t_index = 0
    columns: dict[str, list[int]] = {}
    if set(EXPORT_TRAJECTORY_AS_SAMPLES.values()) <= set(header) and "t" not in header:
        # an exported trial's trajectory file (docs/data.md): its time and the HIP as recorded
        t_index = header.index(EXPORT_TRAJECTORY_AS_SAMPLES["t"])
        columns[PRIMARY_POINT] = [header.index(EXPORT_TRAJECTORY_AS_SAMPLES[a]) for a in "xyz"]
    elif not header or header[0] != "t":
        raise ValueError(f"{where}: the first column must be 't' (seconds), got {header[:1]}")
    elif header[1:] == ["x", "y", "z"]:
        columns[PRIMARY_POINT] = [1, 2, 3]
    else:
        for i, name in enumerate(header[1:], start=1):
            point, _, axis = name.rpartition(".")
            if axis not in ("x", "y", "z"):
                raise ValueError(f"{where}: column {name!r} is not POINT.x|y|z")
            check_point_name(point)
            columns.setdefault(point, [0, 0, 0])["xyz".index(axis)] = i
        for point, idx in columns.items():
            if 0 in idx:
                raise ValueError(f"{where}: point {point} lacks one of its x, y, z columns")
    if not columns:
        raise ValueError(f"{where}: no point columns")
    times, rows = [], []
    for line_no, record in enumerate(reader, start=2):
        if not record or not "".join(record).strip():
            continue
        try:
            t = float(record[t_index])
            row = {point: tuple(float(record[i]) for i in idx) for point, idx in columns.items()}
        except (ValueError, IndexError):
            raise ValueError(f"{where}: line {line_no} is not numbers in every column") from None
        if not math.isfinite(t) or not all(math.isfinite(v) for p in row.values() for v in p):
            raise ValueError(f"{where}: line {line_no} has a non-finite number")
        if times and t < times[-1]:
            raise ValueError(f"{where}: line {line_no}: times must not go back")
        times.append(t)
        rows.append(row)
    if not rows:
        raise ValueError(f"{where}: no rows")
    return ReplayTrack(tuple(times), tuple(rows))


def write_csv(times, rows) -> str:
    """The multi-point CSV of rows (point name → xyz), points in the first row's order."""
    names = list(rows[0])
    out = io.StringIO()
    out.write(",".join(["t"] + [f"{n}.{a}" for n in names for a in "xyz"]) + "\n")
    for t, row in zip(times, rows):
        out.write(",".join([repr(float(t))] + [repr(float(v)) for n in names for v in row[n]]) + "\n")
    return out.getvalue()


class ReplayCursor:
    """Which rows are due: `due(elapsed_s)` → the (index, row) pairs whose time has come since
    the last call; `done` once a non-looping replay has given its last row."""

    def __init__(self, track: ReplayTrack, *, loop: bool):
        self.track, self.loop = track, loop
        self._next = 0
        self._base = 0.0  # elapsed time at which the current pass started
        self.last_time: float | None = None  # elapsed time of the last row `due` gave (the source's clock)
        self.passes = 0
        self.done = False

    def next_time(self) -> float | None:
        if self.done:
            return None
        return self._base + self.track.times[self._next] - self.track.times[0]

    def due(self, elapsed_s: float) -> list[tuple[int, dict]]:
        out = []
        while not self.done and (when := self.next_time()) <= elapsed_s:
            out.append((self._next, self.track.rows[self._next]))
            self.last_time = when
            self._next += 1
            if self._next == len(self.track.rows):
                self.passes += 1
                if self.loop:
                    self._base += self.track.duration_s + self.track.period_s
                    self._next = 0
                else:
                    self.done = True
        return out
