"""The mailbox between the hub process (asyncio) and the loop process (1 kHz).

A pair of AF_UNIX SOCK_SEQPACKET sockets: message boundaries are kept, each record is one
msgpack array `[kind, ...]`, and both ends are non-blocking. The loop drains its inbox at the
start of a tick and never waits: a full socket means the record is dropped and counted (state
frames are latest-value anyway), never a blocked tick, and nothing spins on data written by a
lower-priority process (that stalled the machine for 30-65 ms, docs/reference.md "Design
measurements").

A doorbell (an 8-byte counter in a shared memfd) saves the loop a `recv` syscall on the ~99 % of
ticks where the hub wrote nothing: the hub bumps the counter after each send, the loop reads it
once per tick (one memory read, never in a loop) and reads as many records as it was rung for,
no more. Measured on this machine, the empty non-blocking `recv` alone was p50 5 µs / p99 34 µs
of a tick; counting also spares a tick that has records the last `recv`, the one that finds the
socket empty and raises (~1.2 µs of a 2.6 µs drain of one record, warm).

The records each direction carries are declared once in server/ipc/records.py (frozen dataclasses,
`[tag, *fields]` on the socket); their tables are in docs/architecture.md "The mailbox", written
from those declarations by server/ipc/doc.py. The cue channel (loop → device host process,
devices/feed.py) is a second pair of the same kind.
"""

from __future__ import annotations

import mmap
import os
import socket
import struct

import msgpack

from server.ipc.records import BadRecord, Channel, Malformed, Record

MAX_RECORD_BYTES = 256 * 1024
DRAIN_LIMIT = 1024  # records read in one call at most: a flood waits for the next tick, never stalls this one
_BUFFER_BYTES = 1 << 20


def channel_pair() -> tuple[socket.socket, socket.socket]:
    a, b = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    for s in (a, b):
        s.setblocking(False)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, _BUFFER_BYTES)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, _BUFFER_BYTES)
    return a, b


def pack(record: Record) -> bytes:
    return msgpack.packb(record.to_array(), use_bin_type=True)


def unpack(data: bytes, channel: Channel) -> Record:
    """The record in `data`; BadRecord when it is none of `channel`'s (or not msgpack)."""
    try:
        array = msgpack.unpackb(data, raw=False)
    except (ValueError, msgpack.UnpackException) as exc:
        raise BadRecord(f"{channel.name}: not msgpack ({exc})") from None
    return channel.decode(array)


def send_record(sock: socket.socket, record: Record) -> bool:
    """Send one record without blocking; False when the peer's buffer is full (dropped)."""
    try:
        sock.send(pack(record))
        return True
    except (BlockingIOError, InterruptedError):
        return False


class PeerClosed(Exception):
    """The other end of the mailbox went away."""


def drain(sock: socket.socket, channel: Channel, limit: int = DRAIN_LIMIT) -> list[Record | Malformed]:
    """Every record waiting now (at most `limit`: with exactly `limit` waiting, no `recv` finds
    the socket empty), without blocking. One that is no record of `channel` comes out as
    `Malformed` for the receiver to report: the records after it still arrive."""
    records, reset = [], False
    for _ in range(limit):
        try:
            data = sock.recv(MAX_RECORD_BYTES)
        except (BlockingIOError, InterruptedError):
            break
        except ConnectionResetError:
            # A peer that exits with records of ours unread: Linux reports the reset once, before
            # the records it sent last; those still follow, then the close
            if reset:
                raise PeerClosed() from None
            reset = True
            continue
        if not data:
            if records:  # hand over what came before the close; the next call raises
                break
            raise PeerClosed()
        try:
            records.append(unpack(data, channel))
        except BadRecord as exc:
            records.append(Malformed(str(exc)))
    return records


class Doorbell:
    """A counter in shared memory: one writer (the hub) bumps it after each record it sends, one
    reader polls it per tick and reads that many records.

    A stale read only makes a record wait one tick; a count above what is in the socket (a new
    loop reading an old count) only makes one drain find the socket empty. Nothing ever waits on it.
    """

    _FMT = struct.Struct("=Q")

    def __init__(self, fd: int | None = None):
        if fd is None:
            fd = os.memfd_create("viestac-doorbell", 0)
            os.ftruncate(fd, self._FMT.size)
        self.fd = fd
        self._map = mmap.mmap(fd, self._FMT.size)
        self._seen = 0

    def ring(self) -> None:
        self._FMT.pack_into(self._map, 0, (self._FMT.unpack_from(self._map, 0)[0] + 1) & 0xFFFFFFFFFFFFFFFF)

    def rings(self) -> int:
        """How often the counter was bumped since the last call (0: not at all)."""
        value = self._FMT.unpack_from(self._map, 0)[0]
        if value == self._seen:
            return 0
        count = (value - self._seen) & 0xFFFFFFFFFFFFFFFF
        self._seen = value
        return count

    def close(self) -> None:
        self._map.close()
        os.close(self.fd)
