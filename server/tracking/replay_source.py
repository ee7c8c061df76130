"""The `replay:FILE.csv[:loop|:once]` tracker source: a recorded trajectory (server/tracking/replay.py)
played on its own clock, in scene units."""

from __future__ import annotations

import asyncio
import time
from pathlib import Path

from server.tracking import replay
from server.tracking.source_kind import Feed, SourceKind, SourceSpec


def parse(rest: str, text: str) -> SourceSpec:
    loop = True
    path = rest
    for suffix, value in ((":loop", True), (":once", False)):
        if rest.endswith(suffix):
            path, loop = rest[: -len(suffix)], value
    if not path:
        raise ValueError(f"--tracker {text!r}: expected replay:FILE.csv[:loop|:once]")
    track = replay.parse_csv(Path(path).read_text(), where=path)  # fails early, naming the line
    return SourceSpec("replay", "replay", path, loop=loop, nominal_hz=round(1.0 / track.period_s, 3))


async def run(source: Feed) -> None:
    track = replay.parse_csv(Path(source.spec.target).read_text(), where=source.spec.target)
    cursor = replay.ReplayCursor(track, loop=source.spec.loop)
    source.health.connected, source.health.note = True, "playing"
    start = time.monotonic()
    while not cursor.done:
        due = cursor.next_time()
        await asyncio.sleep(max(0.0, start + due - time.monotonic()))
        rows = cursor.due(time.monotonic() - start)
        if rows:
            _, row = rows[-1]  # behind schedule: only the newest row matters
            # its time on the replay's clock, rising across passes (the filters need that)
            source.sample(row, cursor.last_time, 1.0)
    source.health.connected, source.health.note = False, "replay finished"


KIND = SourceKind("replay", "replay:FILE.csv[:loop|:once]", parse, run)
