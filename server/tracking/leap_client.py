"""Client of the Leap Motion service's WebSocket (protocol v6; server/tracking/leap_frames.py).

Connects to ws://127.0.0.1:6437/v6.json (or the UltraleapTrackingWebSocket bridge for the
Gemini software, which serves the same), asks for frames also while unfocused
(`{"background": true}`, `{"focused": true}`; the service sends frames only to the focused
application otherwise), turns gestures off, sets `optimizeHMD` when asked (a head-mounted
Leap), and hands every frame to `on_frame(frame, recv_ns)`. A dropped or refused connection is
retried with a backoff doubling from 0.1 s to 2 s (reset once a frame arrived), so a restarted
service is picked up within 2 s; `on_state(note, connected)` tells the health what is going on.
"""

from __future__ import annotations

import asyncio
import json
import logging
import time
from typing import Callable

from server.tracking import leap_frames

log = logging.getLogger("viestac.tracking.leap")

BACKOFF_FIRST_S = 0.1
BACKOFF_MAX_S = 2.0


async def run(url: str, on_frame: Callable[[leap_frames.LeapFrame, int], None],
              on_state: Callable[[str, bool], None] = lambda note, connected: None, *,
              optimize_hmd: bool | None = None) -> None:
    from websockets.asyncio.client import connect

    backoff = BACKOFF_FIRST_S
    while True:
        try:
            on_state("connecting", False)
            async with connect(url, compression=None, open_timeout=2.0, max_size=1 << 22) as ws:
                on_state("connected", True)
                await ws.send(json.dumps({"enableGestures": False}))
                await ws.send(json.dumps({"background": True}))
                await ws.send(json.dumps({"focused": True}))
                if optimize_hmd is not None:
                    await ws.send(json.dumps({"optimizeHMD": optimize_hmd}))
                async for text in ws:
                    recv_ns = time.monotonic_ns()
                    try:
                        message = json.loads(text)
                    except ValueError:
                        continue
                    kind = leap_frames.kind_of(message)
                    if kind == "frame":
                        backoff = BACKOFF_FIRST_S
                        on_frame(leap_frames.parse_frame(message), recv_ns)
                    elif kind == "version" and message.get("version") != leap_frames.VERSION:
                        log.warning("Leap service speaks protocol version %s, expected %d",
                                    message.get("version"), leap_frames.VERSION)
                    elif kind == "event":
                        state = (message.get("event") or {}).get("state") or {}
                        if state.get("streaming") is False or state.get("attached") is False:
                            on_state("the Leap device is not streaming (unplugged?)", True)
            on_state("the Leap service closed the connection", False)
        except asyncio.CancelledError:
            raise
        except Exception as exc:  # noqa: BLE001 - refused, reset, timeout: all mean "try again"
            on_state(f"no Leap service at {url} ({type(exc).__name__}); retrying", False)
        await asyncio.sleep(backoff)
        backoff = min(backoff * 2, BACKOFF_MAX_S)
