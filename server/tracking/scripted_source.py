"""The `scripted:NAME` tracker source: a scripted demo (server/tracking/scripted.py), exact points in
scene units, so not filtered."""

from __future__ import annotations

import asyncio
import time

from server.tracking import scripted
from server.tracking.source_kind import Feed, SourceKind, SourceSpec


def parse(rest: str, text: str) -> SourceSpec:
    scripted.script(rest)
    return SourceSpec("scripted", "scripted", rest, nominal_hz=scripted.RATE_HZ)


async def run(source: Feed) -> None:
    fn = scripted.script(source.spec.target)
    period = 1.0 / source.spec.nominal_hz
    source.health.connected, source.health.note = True, "running"
    start = time.monotonic()
    k = 0
    while True:
        k += 1
        await asyncio.sleep(max(0.0, start + k * period - time.monotonic()))
        t = time.monotonic() - start
        source.sample(fn(t), t, 1.0)


KIND = SourceKind("scripted", "scripted:NAME", parse, run, filtered=False)
