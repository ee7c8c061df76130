"""`viestac emulate leap --frames FILE [--rate 110] [--port 6437]`: a stand-in for the Leap Motion
service's WebSocket (protocol v6, server/tracking/leap_frames.py) with no hardware.

FILE is either recorded frames (`.jsonl`: one v6 frame per line, as the service sent them; ids
and timestamps are re-stamped) or a trajectory (`.csv`, the multi-point format of
server/tracking/replay.py, positions in the Leap's frame in millimetres) from which frames are
built. Frames go out at `--rate` on absolute deadlines (no drift), looping unless `--once`.

As the service does, it greets with `{"serviceVersion", "version": 6}` and streams frames only
to a client that is focused or asked for background frames (`{"focused": true}` or
`{"background": true}`); `{"focused": false}` without background stops them. `--timeline FILE`
appends one line per frame sent, `frame_id monotonic_ns`, for latency measurements.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import time
from pathlib import Path

from server.tracking import leap_frames, replay

log = logging.getLogger("viestac.leap_emulator")


def load_frames(path: str | Path) -> list[dict]:
    """The frames' contents (points or whole frames) to serve, in order."""
    path = Path(path)
    text = path.read_text()
    if path.suffix == ".jsonl":
        frames = [json.loads(line) for line in text.splitlines() if line.strip()]
        if not frames:
            raise ValueError(f"{path}: no frames")
        return frames
    track = replay.parse_csv(text, where=str(path))
    return [leap_frames.build_frame(0, 0, row) for row in track.rows]


class LeapEmulator:
    def __init__(self, frames: list[dict], *, rate_hz: float = leap_frames.NOMINAL_HZ, loop: bool = True,
                 timeline: Path | None = None):
        self.frames, self.rate_hz, self.loop = frames, float(rate_hz), loop
        self.timeline = open(timeline, "a", buffering=1) if timeline else None
        self.frame_id = 0
        self.clients: dict = {}  # connection → {"focused", "background"}
        self._t0 = time.monotonic_ns()
        self.finished = asyncio.Event()

    async def handler(self, connection) -> None:
        self.clients[connection] = {"focused": False, "background": False}
        try:
            await connection.send(json.dumps(leap_frames.version_message()))
            async for text in connection:
                try:
                    message = json.loads(text)
                except ValueError:
                    continue
                if isinstance(message, dict):
                    for key in ("focused", "background"):
                        if isinstance(message.get(key), bool):
                            self.clients[connection][key] = message[key]
        finally:
            self.clients.pop(connection, None)

    def _wants_frames(self, state: dict) -> bool:
        return state["focused"] or state["background"]

    async def stream(self) -> None:
        period_ns = int(1e9 / self.rate_hz)
        deadline = time.monotonic_ns()
        index = 0
        while True:
            deadline += period_ns
            delay = (deadline - time.monotonic_ns()) / 1e9
            if delay > 0:
                await asyncio.sleep(delay)
            elif delay < -0.1:  # a long stall: resynchronise rather than burst
                deadline = time.monotonic_ns()
            if index == len(self.frames):
                if not self.loop:
                    self.finished.set()
                    return
                index = 0
            frame = dict(self.frames[index])
            index += 1
            self.frame_id += 1
            now = time.monotonic_ns()
            frame["id"] = self.frame_id
            frame["timestamp"] = (now - self._t0) // 1000
            frame["currentFrameRate"] = self.rate_hz
            text = json.dumps(frame)
            targets = [c for c, state in list(self.clients.items()) if self._wants_frames(state)]
            sent_ns = time.monotonic_ns()
            for connection in targets:
                try:
                    await connection.send(text)
                except Exception:  # noqa: BLE001 - a client that went: the handler drops it
                    pass
            if self.timeline is not None and targets:
                self.timeline.write(f"{self.frame_id} {sent_ns}\n")


async def serve(args: argparse.Namespace) -> None:
    from websockets.asyncio.server import serve as ws_serve

    emulator = LeapEmulator(load_frames(args.frames), rate_hz=args.rate, loop=not args.once,
                            timeline=Path(args.timeline) if args.timeline else None)
    async with ws_serve(emulator.handler, args.host, args.port, compression=None) as server:
        port = server.sockets[0].getsockname()[1]
        print(f"Leap Motion emulator: ws://{args.host}:{port}/v6.json ({len(emulator.frames)} frames at "
              f"{args.rate:g} Hz{'' if not args.once else ', once'})", flush=True)
        streamer = asyncio.create_task(emulator.stream())
        if args.once:
            await emulator.finished.wait()
        else:
            await streamer


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="viestac emulate leap", description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", required=True, help="recorded frames (.jsonl) or a trajectory in Leap mm (.csv)")
    parser.add_argument("--rate", type=float, default=leap_frames.NOMINAL_HZ, help="frames per second (default 110)")
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=6437, help="0 picks a free port (printed)")
    parser.add_argument("--once", action="store_true", help="serve the frames once, then exit")
    parser.add_argument("--realtime", action="store_true",
                        help="ask for SCHED_FIFO (as a measuring instrument: its send stamps must not wait for a CPU)")
    parser.add_argument("--timeline", help="append 'frame_id monotonic_ns' per frame sent to this file")
    args = parser.parse_args(argv)
    if not 1 <= args.rate <= 1000:
        parser.error("--rate must be in 1..1000")
    if args.realtime:
        from devices.realtime import fifo_this_thread

        fifo_this_thread()
    try:
        asyncio.run(serve(args))
    except KeyboardInterrupt:
        pass
    return 0
