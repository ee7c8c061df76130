"""The clients of `viestac bench faults`: a participant that holds a contact cue, a viewer, slow
readers that never read, and a poller of the REST API. Each only records what it saw, stamped on
CLOCK_MONOTONIC (ns); server/bench/faults_measure.py turns the records into numbers."""

from __future__ import annotations

import asyncio
import base64
import contextlib
import http.client
import json
import math
import os
import socket
import threading
import time
from urllib.parse import urlsplit

import msgpack
import websockets

from server.bench.load import LATENCY_ANGLE_DEG, LATENCY_IN
from server.wire import codec

_A = math.radians(LATENCY_ANGLE_DEG)
# 3 mm inside the contact-angle dome at 30°: the FerroVibe's tilt cue stays on (100 %, 330°).
CONTACT_POS = (0.0, round(-LATENCY_IN * math.sin(_A), 9), round(LATENCY_IN * math.cos(_A), 9))
TRACKER_HZ = 100.0


class WsClient:
    """A /ws client that records every state and health message it receives:
    states: (recv ns, tick, tick's t in ns, frame bytes, hip); health: (recv ns, status, codes)."""

    def __init__(self, url: str, role: str, fmt: str = "msgpack", name: str = "bench-faults"):
        self.url, self.role, self.fmt, self.name = url, role, fmt, name
        self.states: list[tuple[int, int, int, int, tuple]] = []
        self.health: list[tuple[int, str, tuple | None]] = []
        self.errors: list[tuple[int, str]] = []
        self.closed_at: int | None = None
        self.client_id: int | None = None
        self.ws = None
        self._reader: asyncio.Task | None = None

    async def connect(self) -> None:
        self.closed_at = None
        self.ws = await websockets.connect(self.url, subprotocols=[f"viestac.v1.{self.fmt}"], compression=None,
                                           max_size=1 << 22, max_queue=None)
        await self.send({"type": "hello", "v": 1, "role": self.role, "client": self.name})
        self._reader = asyncio.create_task(self._read())

    async def send(self, message: dict) -> None:
        await self.ws.send(codec.encode(message, self.fmt))

    async def send_raw(self, data: bytes | str) -> None:
        await self.ws.send(data)

    async def _read(self) -> None:
        try:
            async for data in self.ws:
                now = time.monotonic_ns()
                message = codec.decode(data, self.fmt)
                kind = message.get("type")
                if kind == "state":
                    self.states.append((now, message["tick"], round(message["t"] * 1e9), len(data),
                                        tuple(message["hip"])))
                elif kind == "health":
                    reasons = message.get("reasons")
                    codes = tuple(r.get("code") for r in reasons) if isinstance(reasons, list) else None
                    self.health.append((now, message.get("status"), codes))
                elif kind == "welcome":
                    self.client_id = message.get("client_id")
                elif kind == "error":
                    self.errors.append((now, message.get("code")))
        except websockets.ConnectionClosed:
            pass
        finally:
            self.closed_at = time.monotonic_ns()

    async def close(self) -> None:
        if self.ws is not None:
            await self.ws.close()
        if self._reader is not None:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await self._reader

    def state_times(self) -> list[int]:
        return [s[0] for s in self.states]


class Participant(WsClient):
    """A participant whose tracker presses into the dome at TRACKER_HZ, so the tilt cue is on,
    until paused or closed; it reconnects on demand (tracker loss)."""

    def __init__(self, url: str, fmt: str = "msgpack"):
        super().__init__(url, "participant", fmt, "bench-faults-participant")
        self.paused = False
        self.seq = 0
        self._sender: asyncio.Task | None = None

    async def start(self) -> None:
        await self.connect()
        self._sender = asyncio.create_task(self._send_loop())

    async def _send_loop(self) -> None:
        next_t = time.monotonic()
        while True:
            if not self.paused:
                with contextlib.suppress(websockets.ConnectionClosed):
                    await self.tracker(CONTACT_POS)
            next_t += 1.0 / TRACKER_HZ
            await asyncio.sleep(max(0.0, next_t - time.monotonic()))

    async def tracker(self, pos) -> None:
        await self.send({"type": "tracker", "seq": self.seq, "t": time.monotonic() * 1e3, "pos": list(pos)})
        self.seq += 1

    async def stop(self) -> None:
        if self._sender is not None:
            self._sender.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._sender
            self._sender = None
        await self.close()


@contextlib.contextmanager
def slow_readers(base: str, count: int):
    """`count` observers that complete the WebSocket handshake and never read a byte, with a
    small receive buffer, so the server's sends to them back up at once."""
    parts = urlsplit(base)
    socks = []
    try:
        for _ in range(count):
            s = socket.create_connection((parts.hostname, parts.port))
            s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
            key = base64.b64encode(os.urandom(16)).decode()
            s.sendall((f"GET /ws HTTP/1.1\r\nHost: {parts.netloc}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                       f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n"
                       f"Sec-WebSocket-Protocol: viestac.v1.msgpack\r\n\r\n").encode())
            socks.append(s)
        yield socks
    finally:
        for s in socks:
            s.close()


class Poller:
    """Polls a JSON endpoint of the server every `interval_s` on one kept-alive HTTP connection,
    in a thread (the bench's event loop stays free for the clients): (t ns, answer or None)."""

    def __init__(self, base: str, path: str, interval_s: float):
        parts = urlsplit(base)
        self.host, self.port, self.path, self.interval_s = parts.hostname, parts.port, path, interval_s
        self.samples: list[tuple[int, dict | None]] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"poll {path}", daemon=True)

    def _run(self) -> None:
        conn = None
        while not self._stop.is_set():
            t0 = time.monotonic()
            try:
                if conn is None:
                    conn = http.client.HTTPConnection(self.host, self.port, timeout=2.0)
                conn.request("GET", self.path)
                response = conn.getresponse()
                body = response.read()
                answer = json.loads(body) if response.status == 200 else None
            except (OSError, http.client.HTTPException, ValueError):
                answer = None
                if conn is not None:
                    conn.close()
                conn = None
            self.samples.append((time.monotonic_ns(), answer))
            self._stop.wait(max(0.0, self.interval_s - (time.monotonic() - t0)))
        if conn is not None:
            conn.close()

    def __enter__(self) -> Poller:
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join(timeout=5)

    def latest(self) -> dict | None:
        return next((a for _, a in reversed(self.samples) if a is not None), None)


def health_status(answer: dict | None) -> str:
    """A /api/health answer's status; no answer (the hub busy or gone) counts as not ok."""
    return "unreachable" if answer is None else str(answer.get("status"))


def reason_codes(answer: dict | None) -> tuple | None:
    """The `reasons` codes of a /api/health answer; None when the server does not report reasons."""
    reasons = (answer or {}).get("reasons")
    return tuple(r.get("code") for r in reasons) if isinstance(reasons, list) else None


def udp_tracker(address: str):
    """A sender of tracker datagrams to the loop's tracker UDP port ('HOST:PORT')."""
    host, _, port = address.rpartition(":")
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    seq = [0]

    def send(pos) -> None:
        sock.sendto(msgpack.packb({"type": "tracker", "seq": seq[0], "t": time.monotonic() * 1e3,
                                   "pos": list(pos)}), (host, int(port)))
        seq[0] += 1
    send.close = sock.close
    return send
