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
import random
import socket
import threading
import time
from urllib.parse import urlsplit

import msgpack
import websockets

from server.bench.load import LATENCY_ANGLE_DEG, LATENCY_IN
from server.launcher import admin_token, auth_headers
from server.wire import codec

_A = math.radians(LATENCY_ANGLE_DEG)
# 3 mm inside the contact-angle dome at 30°: the FerroVibe's tilt cue stays on (100 %, 330°).
CONTACT_POS = (0.0, round(-LATENCY_IN * math.sin(_A), 9), round(LATENCY_IN * math.cos(_A), 9))
_B = math.radians(LATENCY_ANGLE_DEG + 5.0)
NUDGE_POS = (0.0, round(-LATENCY_IN * math.sin(_B), 9), round(LATENCY_IN * math.cos(_B), 9))  # another tilt
TRACKER_HZ = 100.0


class WsClient:
    """A /ws client that records every state and health message it receives:
    states: (recv ns, tick, tick's t in ns, frame bytes, hip); health: (recv ns, status, codes);
    published: (recv ns, the state's `frame`, the loop's publish counter)."""

    def __init__(self, url: str, role: str, fmt: str = "msgpack", name: str = "bench-faults",
                 token: str | None = None):
        self.url, self.role, self.fmt, self.name = url, role, fmt, name
        self.token = token or admin_token(url)  # the bench server's admin token unless given
        self.states: list[tuple[int, int, int, int, tuple]] = []
        self.published: list[tuple[int, int]] = []  # (recv ns, the loop's publish counter `frame`)
        self.health: list[tuple[int, str, tuple | None]] = []
        self.errors: list[tuple[int, str]] = []
        self.unreadable: list[str] = []
        self.closed_at: int | None = None
        self.client_id: int | None = None
        self.ws = None
        self._reader: asyncio.Task | None = None

    async def connect(self) -> None:
        self.closed_at = None
        self.ws = await websockets.connect(self.url, subprotocols=[f"viestac.v1.{self.fmt}"], compression=None,
                                           max_size=1 << 22, max_queue=None)
        await self.send({"type": "hello", "v": 1, "role": self.role, "client": self.name,
                         **({"token": self.token} if self.token else {})})
        self._reader = asyncio.create_task(self._read())

    async def send(self, message: dict) -> None:
        await self.ws.send(codec.encode(message, self.fmt))

    async def send_raw(self, data: bytes | str) -> None:
        await self.ws.send(data)

    async def _read(self) -> None:
        try:
            async for data in self.ws:
                try:
                    self._take(time.monotonic_ns(), data)
                except Exception as exc:  # one odd frame must not end the recording: count it
                    self.unreadable.append(repr(exc))
        except websockets.ConnectionClosed:
            pass
        finally:
            self.closed_at = time.monotonic_ns()

    def _take(self, now: int, data) -> None:
        message = codec.decode(data, self.fmt)
        kind = message.get("type")
        if kind == "state":
            self.states.append((now, message["tick"], round(message["t"] * 1e9), len(data), tuple(message["hip"])))
            self.published.append((now, message["frame"]))
        elif kind == "health":
            reasons = message.get("reasons")
            codes = tuple(r.get("code") for r in reasons) if isinstance(reasons, list) else None
            self.health.append((now, message.get("status"), codes))
        elif kind == "welcome":
            self.client_id = message.get("client_id")
        elif kind == "error":
            self.errors.append((now, message.get("code")))

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
        self.ttl_ms: float | None = None  # stamped on each sample when set (protocol v1.4 `ttl`)
        self.pos = CONTACT_POS
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
                    await self.tracker(self.pos)
            next_t += 1.0 / TRACKER_HZ
            await asyncio.sleep(max(0.0, next_t - time.monotonic()))

    async def nudge(self) -> None:
        """Press at another angle for a moment and back: two changes of the tilt cue, so every
        device is given the current cue again whatever an earlier fault left it showing."""
        self.pos = NUDGE_POS
        await asyncio.sleep(0.06)
        self.pos = CONTACT_POS

    async def tracker(self, pos) -> None:
        message = {"type": "tracker", "seq": self.seq, "t": time.monotonic() * 1e3, "pos": list(pos)}
        if self.ttl_ms is not None:
            message["ttl"] = self.ttl_ms
        await self.send(message)
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
        self.headers = auth_headers(base)
        self.samples: list[tuple[int, dict | None]] = []
        self.answer_ms: list[tuple[int, float]] = []  # (t ns, how long the request took, ms; a failed one too)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"poll {path}", daemon=True)

    def _run(self) -> None:
        conn = None
        while not self._stop.is_set():
            t0 = time.monotonic()
            try:
                if conn is None:
                    conn = http.client.HTTPConnection(self.host, self.port, timeout=2.0)
                conn.request("GET", self.path, headers=self.headers)
                response = conn.getresponse()
                body = response.read()
                answer = json.loads(body) if response.status == 200 else None
            except (OSError, http.client.HTTPException, ValueError):
                answer = None
                if conn is not None:
                    conn.close()
                conn = None
            now_ns = time.monotonic_ns()
            self.samples.append((now_ns, answer))
            self.answer_ms.append((now_ns, round((now_ns / 1e9 - t0) * 1000.0, 3)))
            self._stop.wait(max(0.0, self.interval_s - (time.monotonic() - t0)))
        if conn is not None:
            conn.close()

    def __enter__(self) -> Poller:
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join(timeout=5)

    def slowest_ms(self, t0_ns: int, t1_ns: int) -> float | None:
        """The slowest answer that came between t0 and t1 (ms); None: none came."""
        return max((ms for t, ms in self.answer_ms if t0_ns <= t <= t1_ns), default=None)

    def latest(self) -> dict | None:
        return next((a for _, a in reversed(self.samples) if a is not None), None)


def health_status(answer: dict | None) -> str:
    """A /api/health answer's status; no answer (the hub busy or gone) counts as not ok."""
    return "unreachable" if answer is None else str(answer.get("status"))


def reason_codes(answer: dict | None) -> tuple | None:
    """The `reasons` codes of a /api/health answer; None when the server does not report reasons."""
    reasons = (answer or {}).get("reasons")
    return tuple(r.get("code") for r in reasons) if isinstance(reasons, list) else None


FLOOD_MESSAGES = {"key": {"type": "input", "key": "a", "action": "press"},
                  "tracker": {"type": "tracker", "seq": 1, "t": 0.0, "pos": list(CONTACT_POS)},
                  "jitter": {"type": "tracker", "seq": 1, "t": 0.0, "pos": list(CONTACT_POS)}}  # moved each send
JITTER_SURFACE = LATENCY_IN + 0.003  # the dilated dome's surface (the contact-angle dome + the proxy radius)


def jittered(rng: random.Random, seq: int) -> dict:
    """A tracker sample 0-1 mm inside the dome at 25-35°: the cues change almost every tick (issue 35)."""
    angle, r = math.radians(rng.uniform(25.0, 35.0)), JITTER_SURFACE - rng.uniform(0.0, 0.001)
    return {"type": "tracker", "seq": seq, "t": time.monotonic() * 1000.0,
            "pos": [0.0, round(-r * math.sin(angle), 9), round(r * math.cos(angle), 9)]}


async def flood(url: str, what: str, rate: int, seconds: float, token: str | None = None) -> dict:
    """A participant that sends FLOOD_MESSAGES[what] `rate` times a second for `seconds`, in
    batches every 10 ms; run in a process of its own (`python -m server.bench.faults_clients`) so
    the bench's viewer is not starved by its own sends. `jitter`: a tracker held 0-1 mm inside the
    dome at a new point each send, one send a millisecond at 1000 a second (the loop takes one
    sample a tick: a batch would change the cues once)."""
    client = WsClient(url, "participant", name=f"bench-faults-{what}-flood", token=token)
    await client.connect()
    await asyncio.sleep(0.5)
    data = codec.encode(FLOOD_MESSAGES[what], client.fmt)
    rng = random.Random(35)
    every_s = 0.001 if what == "jitter" else 0.01
    t0 = time.monotonic_ns()
    sent = 0
    error = None
    next_t = time.monotonic()
    try:
        while time.monotonic_ns() - t0 < seconds * 1e9:
            for _ in range(max(1, round(rate * every_s))):
                if what == "jitter":
                    data = codec.encode(jittered(rng, sent + 1), client.fmt)
                await client.ws.send(data)
                sent += 1
            next_t += every_s
            await asyncio.sleep(max(0.0, next_t - time.monotonic()))
    except websockets.ConnectionClosed as exc:  # the server may close a flooding connection: an answer too
        error = repr(exc)
    t1 = time.monotonic_ns()
    await asyncio.sleep(0.2)
    codes = sorted({c for _, c in client.errors})
    closed = client.closed_at is not None
    await client.close()
    return {"t0_ns": t0, "t1_ns": t1, "sent": sent, "error_codes": codes, "closed": closed, "error": error}


def main() -> None:
    import argparse

    parser = argparse.ArgumentParser(description="a flooding participant of viestac bench faults")
    parser.add_argument("--url", required=True)
    parser.add_argument("--what", choices=sorted(FLOOD_MESSAGES), required=True)
    parser.add_argument("--rate", type=int, default=10_000)
    parser.add_argument("--seconds", type=float, default=1.0)
    parser.add_argument("--token", default=None, help="the server's access token (sent in the hello)")
    args = parser.parse_args()
    print(json.dumps(asyncio.run(flood(args.url, args.what, args.rate, args.seconds, args.token))), flush=True)


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


if __name__ == "__main__":
    main()
