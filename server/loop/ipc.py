"""The mailbox between the hub process (asyncio) and the loop process (1 kHz).

A pair of AF_UNIX SOCK_SEQPACKET sockets: message boundaries are kept, each record is one
msgpack array `[kind, ...]`, and both ends are non-blocking. The loop drains its inbox at the
start of a tick and never waits: a full socket means the record is dropped and counted (state
frames are latest-value anyway), never a blocked tick, and nothing spins on data written by a
lower-priority process (shared/reference/loop-probe.md: that stalled the machine for 60 ms).

Records, hub → loop: ["tracker", client_id, seq, t_ms, [x,y,z], quat|None, recv_ns],
["input", client_id, key, action], ["stop"].
Records, loop → hub: ["hello", info], ["scene", scene_map, hash], ["state", state_map],
["log", level, text].
"""

from __future__ import annotations

import socket

import msgpack

MAX_RECORD_BYTES = 256 * 1024
_BUFFER_BYTES = 1 << 20


def channel_pair() -> tuple[socket.socket, socket.socket]:
    a, b = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    for s in (a, b):
        s.setblocking(False)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, _BUFFER_BYTES)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, _BUFFER_BYTES)
    return a, b


def send_record(sock: socket.socket, record: list) -> bool:
    """Send one record without blocking; False when the peer's buffer is full (dropped)."""
    try:
        sock.send(msgpack.packb(record, use_bin_type=True))
        return True
    except (BlockingIOError, InterruptedError):
        return False


class PeerClosed(Exception):
    """The other end of the mailbox went away."""


def drain(sock: socket.socket, limit: int = 1024) -> list[list]:
    """Every record waiting now (at most `limit`), without blocking."""
    records = []
    for _ in range(limit):
        try:
            data = sock.recv(MAX_RECORD_BYTES)
        except (BlockingIOError, InterruptedError):
            break
        if not data:
            raise PeerClosed()
        records.append(msgpack.unpackb(data, raw=False))
    return records
