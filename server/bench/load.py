"""Load generator for `viestac bench loop`: N viewers at 60 Hz plus tracker clients at 120 Hz;
and `cpu_hogs(n)`, the busy machine of `viestac bench faults --load N`.

Runs in its own process (so it does not share a GIL with the bench driver) with real
`websockets` clients. Viewers only receive and count state frames; trackers send positions
sweeping along the contact-angle hemisphere, slightly inside it, so the god-object, the contact
gate and the tilt cues are all exercised. Prints one JSON object when done.

`--latency-tracker` adds the participant tracker of `viestac bench latency`: at 120 Hz it holds
the HIP either 3 mm inside the dome (tilt cue on) or well above it (cue off), switches every
66-100 ms, and reports the CLOCK_MONOTONIC send time of every switching message; over /ws, or
with `--latency-udp HOST:PORT` to the loop's tracker UDP port.

`--format json` makes the viewers JSON clients (`viestac bench roundtrip --format json`).

`--token` is the server's access token (the bench's admin token, which holds the control lease,
so its participant trackers may drive the HIP); every client says it in its hello.

The measured window starts `--warmup` seconds after the last client connected, not after the
process started: on a loaded machine the imports and connections alone took seconds, and a window
counted from the start held no tracker sample. The process prints `ready` on a line of its own when
every client is connected (the bench waits for it), and its JSON result last.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import math
import random
import select
import socket
import time

import msgpack
import websockets

from server.cpu_plan import pin_process
from server.wire import codec

TOKEN: str | None = None  # --token: this process's clients all use it
HOG = "while True: pass"  # one CPU's worth of work at normal priority: a headset runtime, a screen recorder


@contextlib.contextmanager
def cpu_hogs(n: int):
    """`n` processes that each keep a CPU busy beside the server while the block runs (a lab PC is
    often busy, issue 35); stopped when it ends, however it ends."""
    import subprocess
    import sys

    hogs = [subprocess.Popen([sys.executable, "-c", HOG]) for _ in range(n)]
    try:
        yield hogs
    finally:
        for hog in hogs:
            hog.kill()
        for hog in hogs:
            hog.wait()


class Window:
    """When the run counts: `warmup_s` after the last of `clients` connections is up, for
    `seconds`; the clients stop `STOP_AFTER_S` after it. Until then every bound is infinite."""

    STOP_AFTER_S = 0.2

    def __init__(self, clients: int, warmup_s: float, seconds: float):
        self._waiting, self._warmup_s, self._seconds = clients, warmup_s, seconds
        self.start = self.end = self.stop = math.inf
        self.ready = asyncio.Event()
        if clients == 0:
            self._open()

    async def connected(self) -> None:
        """One client's connection is up; returns once every client's is."""
        self._waiting -= 1
        if self._waiting == 0:
            self._open()
        await self.ready.wait()

    def _open(self) -> None:
        self.start = time.monotonic() + self._warmup_s
        self.end = self.start + self._seconds
        self.stop = self.end + self.STOP_AFTER_S
        print("ready", flush=True)
        self.ready.set()


READY_TIMEOUT_S = 120.0  # a hung load generator; a loaded machine took seconds, never minutes


def wait_ready(proc, timeout_s: float = READY_TIMEOUT_S) -> None:
    """Until the load generator `proc` (a Popen with text stdout) printed `ready`: every client is
    connected and its warm-up has begun. A generator that exits or hangs first is an error."""
    ready, _, _ = select.select([proc.stdout], [], [], timeout_s)
    line = proc.stdout.readline() if ready else ""
    if line.strip() != "ready":
        proc.kill()
        raise RuntimeError(f"the load generator did not get its clients connected within {timeout_s:.0f} s"
                           f" (exit code {proc.poll()}, said {line.strip()!r})")


def hello(role: str, client: str) -> dict:
    """The hello of a bench client, with the access token when there is one (protocol v1.3)."""
    return {"type": "hello", "v": 1, "role": role, "client": client, **({"token": TOKEN} if TOKEN else {})}


async def viewer(url: str, counts: list[int], index: int, window: Window, fmt: str = "msgpack") -> None:
    """An observer that decodes every frame, in msgpack or JSON (`viestac bench roundtrip --format`)."""
    decode = msgpack.unpackb if fmt == "msgpack" else json.loads
    async with websockets.connect(url, subprotocols=[f"viestac.v1.{fmt}"], compression=None, max_size=1 << 20) as ws:
        await ws.send(codec.encode(hello("observer", "bench-viewer"), fmt))
        await window.connected()
        while time.monotonic() < window.stop:
            try:
                data = await asyncio.wait_for(ws.recv(), timeout=max(0.05, window.stop - time.monotonic()))
            except asyncio.TimeoutError:
                break
            now = time.monotonic()
            if window.start <= now < window.end and decode(data).get("type") == "state":
                counts[index] += 1


@contextlib.asynccontextmanager
async def participant(url: str, client: str):
    """A participant connection whose incoming frames are drained (and dropped) meanwhile."""
    async with websockets.connect(url, subprotocols=["viestac.v1.msgpack"], compression=None) as ws:
        await ws.send(msgpack.packb(hello("participant", client)))

        async def drain() -> None:
            async for _ in ws:
                pass

        reader = asyncio.create_task(drain())
        try:
            yield ws
        finally:
            reader.cancel()


async def tracker(url: str, rate_hz: float, phase: float, sent: list[int], window: Window) -> None:
    async with participant(url, "bench-tracker") as ws:
        await window.connected()
        period = 1.0 / rate_hz
        next_t = time.monotonic()
        seq = 0
        radius = 0.6 + 0.06 - 0.003  # 3 mm inside the dilated dome: in contact
        while next_t < window.stop:
            angle = math.radians(80.0 * math.sin(2 * math.pi * 0.25 * next_t + phase))
            pos = [0.0, -radius * math.sin(angle), radius * math.cos(angle)]
            await ws.send(msgpack.packb({"type": "tracker", "seq": seq, "t": time.monotonic() * 1e3, "pos": pos}))
            sent[0] += 1
            seq += 1
            next_t += period
            await asyncio.sleep(max(0.0, next_t - time.monotonic()))


LATENCY_ANGLE_DEG = 30.0     # a fixed contact angle: the tilt cue is on at 100 %, direction 330°
LATENCY_IN = 0.6 + 0.06 - 0.003  # 3 mm inside the dilated dome (radius + proxy radius): in contact
LATENCY_OUT = 0.6 + 0.06 + 0.03  # 30 mm outside it: far beyond the gate's 2 mm hysteresis band


LATENCY_RATE_HZ = 120.0
LATENCY_EVERY = (8, 12)   # samples between switches: 66-100 ms at 120 Hz
LATENCY_SWITCH_HZ = LATENCY_RATE_HZ / (sum(LATENCY_EVERY) / 2)  # 12 switches per second on average


async def latency_tracker(url: str, rate_hz: float, switches: list[list], window: Window, seed: int = 8,
                          udp: tuple[str, int] | None = None) -> None:
    """Alternate between in contact and well above the dome; record [send t_us, seq, in_contact] of
    each switching message. Between switches the same position is resent at rate_hz, like a real
    tracker. A switch comes after 8-12 samples (66-100 ms at 120 Hz): clear of the gate's 30 ms
    minimum dwell, and random so that switches do not lock to the heartbeat or the tick.
    With `udp` the samples go to the loop's tracker UDP port (a tracker bridge), else over /ws."""
    rng = random.Random(seed)
    a = math.radians(LATENCY_ANGLE_DEG)
    inside, above = ([0.0, -r * math.sin(a), r * math.cos(a)] for r in (LATENCY_IN, LATENCY_OUT))
    async with contextlib.AsyncExitStack() as stack:
        if udp is None:
            ws = await stack.enter_async_context(participant(url, "bench-latency"))
            send = ws.send
        else:
            sock = stack.enter_context(socket.socket(socket.AF_INET, socket.SOCK_DGRAM))
            sock.setblocking(False)

            async def send(data: bytes) -> None:
                sock.sendto(data, udp)
        await window.connected()
        period = 1.0 / rate_hz
        next_t = time.monotonic()
        seq = 0
        in_contact = False
        left = rng.randint(*LATENCY_EVERY)  # samples until the next switch
        while next_t < window.stop:
            left -= 1
            switch = left == 0
            if switch:
                in_contact = not in_contact
                left = rng.randint(*LATENCY_EVERY)
            t_us = time.monotonic_ns() // 1000  # the emulator stamps with the same clock
            pos = inside if in_contact else above
            await send(msgpack.packb({"type": "tracker", "seq": seq, "t": t_us / 1e3, "pos": pos}))
            if switch:
                switches.append([t_us, seq, in_contact])
            seq += 1
            next_t += period
            await asyncio.sleep(max(0.0, next_t - time.monotonic()))


async def main_async(url: str, viewers: int, trackers: int, warmup_s: float, seconds: float,
                     latency: bool = False, latency_udp: tuple[str, int] | None = None, fmt: str = "msgpack",
                     token: str | None = None) -> dict:
    global TOKEN
    TOKEN = token
    window = Window(viewers + trackers + (1 if latency else 0), warmup_s, seconds)
    counts = [0] * viewers
    sent = [0]
    tasks = [viewer(url, counts, i, window, fmt) for i in range(viewers)]
    tasks += [tracker(url, 120.0, i * 1.3, sent, window) for i in range(trackers)]
    switches: list[list] = []
    if latency:
        tasks.append(latency_tracker(url, LATENCY_RATE_HZ, switches, window, udp=latency_udp))
    await asyncio.gather(*tasks)
    rates = [c / seconds for c in counts]
    result = {"viewers": viewers, "frames_received_per_client_hz": {
        "mean": round(sum(rates) / len(rates), 2) if rates else 0.0,
        "min": round(min(rates), 2) if rates else 0.0}, "tracker_messages": sent[0]}
    if latency:
        result["switches"] = switches
    return result


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--url", required=True)
    parser.add_argument("--viewers", type=int, default=8)
    parser.add_argument("--trackers", type=int, default=2)
    parser.add_argument("--warmup", type=float, default=3.0)
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--latency-tracker", action="store_true",
                        help="add the switching participant tracker of `viestac bench latency`")
    parser.add_argument("--latency-udp", metavar="HOST:PORT", default=None,
                        help="the latency tracker sends to this tracker UDP port instead of /ws")
    parser.add_argument("--format", choices=codec.FORMATS, default="msgpack", help="the viewers' encoding")
    parser.add_argument("--token", default=None, help="the server's access token (sent in every hello)")
    parser.add_argument("--cpus", default=None, metavar="N,N",
                        help="run on these CPUs only (off the loop's CPU when the server keeps it to itself)")
    args = parser.parse_args()
    if args.cpus:
        pin_process(int(cpu) for cpu in args.cpus.split(","))
    udp = None
    if args.latency_udp:
        host, _, port = args.latency_udp.rpartition(":")
        udp = (host, int(port))
    print(json.dumps(asyncio.run(main_async(args.url, args.viewers, args.trackers, args.warmup, args.seconds,
                                            args.latency_tracker, udp, args.format, args.token))))


if __name__ == "__main__":
    main()
