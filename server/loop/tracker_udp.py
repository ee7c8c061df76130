"""Tracker samples over UDP, read by the loop process itself at the start of every tick.

The shortest path from a tracker to the haptic loop. A tracker bridge (Leap Motion, an optical
tracker, anything on the server machine or its network) sends one datagram per sample; the
loop reads every waiting datagram at the start of the next tick, so a sample waits only for
that tick (≤ 1 ms), never for the hub's event loop, which with 64 viewers is busy sending
frames when samples arrive (docs/performance.md "Tracker → device latency"). The WebSocket
tracker message on /ws stays for browsers (WebXR), which cannot send UDP.

A datagram is one tracker message exactly as on /ws (docs/protocol.md): a map with type
"tracker", seq, t, pos and optional quat, point, points and ttl (v1.4: several points of a hand, and
how long the sample is good for, so a bridge that stops is noticed by the loop itself), as msgpack or as UTF-8 JSON (a datagram that starts
with "{" is JSON). Anything else gets one `error` datagram back, in the sender's format, with
the same codes as on /ws, and is counted; the sample is not applied. The sender is named
"udp:HOST:PORT" in the applied-sample rows (/api/trackers) and the recorder's tracker watch.

`parse_datagram` is pure; `TrackerPort` is the thin non-blocking socket adapter the loop polls.
It reads at most MAX_PER_TICK datagrams per tick, so a flood cannot stretch a tick; the rest
wait for the next one.

The port binds to loopback only (`bind` refuses any other address; server/config.py checks the
setting first): it has no authentication, so only the rig PC's own processes, which the rig's
admin controls, can move the HIP through it (docs/security.md).
"""

from __future__ import annotations

import ipaddress
import select
import socket

from server.ipc.records import TrackerSample
from server.wire import codec, messages
from server.wire.codec import WireError

MAX_PER_TICK = 32
MAX_DATAGRAM_BYTES = 16384  # one point: ~60-120 bytes; two hands' 54 points as JSON: ~5 KB
NOTICE_EVERY = 1000        # after the first bad datagram, one log line per this many


def parse_datagram(data: bytes, source: str, recv_ns: int) -> TrackerSample:
    """One datagram → the loop's tracker record (server/ipc/records.py TrackerSample); WireError
    (code, message) when it is not a valid tracker message."""
    fmt = "json" if data[:1] == b"{" else "msgpack"
    if fmt == "json":
        try:
            data = data.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise WireError("bad_encoding", f"JSON datagram is not UTF-8: {exc}") from None
    message = messages.parse_client_message(codec.decode(data, fmt))
    if not isinstance(message, messages.Tracker):
        raise WireError("bad_message", f"the tracker port takes only 'tracker' messages, not '{type(message).__name__.lower()}'")
    return message.loop_record(source, recv_ns)


def error_reply(data: bytes, exc: WireError) -> bytes:
    fmt = "json" if data[:1] == b"{" else "msgpack"
    reply = codec.encode(messages.error(exc.code, exc.message), fmt)
    return reply.encode() if isinstance(reply, str) else reply


class TrackerPort:
    """The loop's end of the tracker UDP socket (bound by the hub, passed to every loop process)."""

    def __init__(self, sock: socket.socket):
        sock.setblocking(False)
        self.sock = sock
        self.received = 0
        self.bad = 0
        self.notices: list[str] = []  # for the hub's log: the first bad datagram, then every NOTICE_EVERY-th
        # Asked every tick whether anything waits: an epoll with timeout 0 answers in ~0.25 µs,
        # where a recvfrom on the empty socket raises (~1.1 µs hot, 5+ µs on a cold cache).
        self._ready = select.epoll()
        self._ready.register(sock.fileno(), select.EPOLLIN)

    def drain(self, now_ns: int) -> list[TrackerSample]:
        if not self._ready.poll(0):
            return []
        records = []
        for _ in range(MAX_PER_TICK):
            try:
                data, address = self.sock.recvfrom(MAX_DATAGRAM_BYTES)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:  # e.g. ECONNREFUSED left over from an error reply to a closed sender
                continue
            source = f"udp:{address[0]}:{address[1]}"
            try:
                records.append(parse_datagram(data, source, now_ns))
                self.received += 1
            except WireError as exc:
                self._refuse(data, address, source, exc)
        return records

    def _refuse(self, data: bytes, address, source: str, exc: WireError) -> None:
        self.bad += 1
        if self.bad == 1 or self.bad % NOTICE_EVERY == 0:
            self.notices.append(f"tracker port: bad datagram from {source} ({exc.code}: {exc.message}); "
                                f"{self.bad} refused so far")
        try:
            self.sock.sendto(error_reply(data, exc), address)
        except OSError:  # a full buffer or a sender that is gone: the count above still tells
            pass


def is_loopback(host: str) -> bool:
    """`host` names this machine's loopback interface only (127.0.0.0/8, ::1 or "localhost")."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def bind(address: tuple[str, int]) -> socket.socket:
    """The hub binds the port once (it outlives loop restarts); OSError says which address failed.
    ValueError for an address that is not loopback (the port has no authentication)."""
    if not is_loopback(address[0]):
        raise ValueError(f"the tracker UDP port binds to loopback only, not {address[0]} (docs/security.md)")
    family = socket.AF_INET6 if ":" in address[0] else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_DGRAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 256 * 1024)
        sock.bind(address)
    except OSError as exc:
        sock.close()
        raise OSError(exc.errno, f"cannot bind the tracker UDP port {address[0]}:{address[1]}: {exc.strerror}; "
                                 "choose another with --tracker-udp HOST:PORT, or --tracker-udp off") from None
    sock.setblocking(False)
    return sock
