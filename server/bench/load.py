"""Load generator for `viestac bench loop`: N viewers at 60 Hz plus tracker clients at 120 Hz.

Runs in its own process (so it does not share a GIL with the bench driver) with real
`websockets` clients. Viewers only receive and count state frames; trackers send positions
sweeping along the contact-angle hemisphere, slightly inside it, so the god-object, the contact
gate and the tilt cues are all exercised. Prints one JSON object when done.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import time

import msgpack
import websockets


async def viewer(url: str, counts: list[int], index: int, window: tuple[float, float], stop: float) -> None:
    async with websockets.connect(url, subprotocols=["viestac.v1.msgpack"], compression=None, max_size=1 << 20) as ws:
        await ws.send(msgpack.packb({"type": "hello", "v": 1, "role": "observer", "client": "bench-viewer"}))
        while time.monotonic() < stop:
            try:
                data = await asyncio.wait_for(ws.recv(), timeout=max(0.05, stop - time.monotonic()))
            except asyncio.TimeoutError:
                break
            now = time.monotonic()
            if window[0] <= now < window[1] and msgpack.unpackb(data).get("type") == "state":
                counts[index] += 1


async def tracker(url: str, rate_hz: float, phase: float, sent: list[int], stop: float) -> None:
    async with websockets.connect(url, subprotocols=["viestac.v1.msgpack"], compression=None) as ws:
        await ws.send(msgpack.packb({"type": "hello", "v": 1, "role": "participant", "client": "bench-tracker"}))

        async def drain() -> None:
            async for _ in ws:
                pass

        reader = asyncio.create_task(drain())
        period = 1.0 / rate_hz
        next_t = time.monotonic()
        seq = 0
        radius = 0.6 + 0.06 - 0.003  # 3 mm inside the dilated dome: in contact
        while next_t < stop:
            angle = math.radians(80.0 * math.sin(2 * math.pi * 0.25 * next_t + phase))
            pos = [0.0, -radius * math.sin(angle), radius * math.cos(angle)]
            await ws.send(msgpack.packb({"type": "tracker", "seq": seq, "t": time.monotonic() * 1e3, "pos": pos}))
            sent[0] += 1
            seq += 1
            next_t += period
            await asyncio.sleep(max(0.0, next_t - time.monotonic()))
        reader.cancel()


async def main_async(url: str, viewers: int, trackers: int, warmup_s: float, seconds: float) -> dict:
    start = time.monotonic()
    window = (start + warmup_s, start + warmup_s + seconds)
    stop = window[1] + 0.2
    counts = [0] * viewers
    sent = [0]
    tasks = [viewer(url, counts, i, window, stop) for i in range(viewers)]
    tasks += [tracker(url, 120.0, i * 1.3, sent, stop) for i in range(trackers)]
    await asyncio.gather(*tasks)
    rates = [c / seconds for c in counts]
    return {"viewers": viewers, "frames_received_per_client_hz": {
        "mean": round(sum(rates) / len(rates), 2) if rates else 0.0,
        "min": round(min(rates), 2) if rates else 0.0}, "tracker_messages": sent[0]}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--url", required=True)
    parser.add_argument("--viewers", type=int, default=8)
    parser.add_argument("--trackers", type=int, default=2)
    parser.add_argument("--warmup", type=float, default=3.0)
    parser.add_argument("--seconds", type=float, default=10.0)
    args = parser.parse_args()
    print(json.dumps(asyncio.run(main_async(args.url, args.viewers, args.trackers, args.warmup, args.seconds))))


if __name__ == "__main__":
    main()
