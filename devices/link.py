"""What goes on the serial link next, and when (docs/device-protocol.md §4.4, §5). Pure: time is
always passed in.

- `LinkBudget`: after writing n bytes at t, the next frame may start at t + n·byte_time/share,
  so the host never fills more than `share` of the line (§5).
- `LatestSlots`: the newest value per key, never a queue. The key that has waited longest goes
  first, and overwriting a waiting value keeps its waiting-since time, so a key that changes
  every tick can neither starve the others nor be starved by them (§4.4).
- `CommandBook`: the layer commands of one device. Pending values wait in LatestSlots; the ones
  written are remembered in write order (what the device has, as far as the host knows), so a
  value the device already has is not sent again and, after a reconnect or a suspected loss,
  everything can be made pending again in the right order.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Hashable, Iterator
from dataclasses import dataclass
from typing import Generic, TypeVar

from server.core.numbers import is_finite_number
from devices.messages import SET_MESSAGES, as_seen_by, overrides, touches

K = TypeVar("K", bound=Hashable)
V = TypeVar("V")

BYTE_TIME_S = 86.8e-6  # 115200 8N1: 10 bits per byte on the wire (10 / 115200 = 86.806 µs)

class LinkBudget:
    """The host's share of the line (§5: 0.5 by default; 86.8 µs per byte at 115200 8N1)."""

    def __init__(self, share: float = 0.5, byte_time_s: float = BYTE_TIME_S):
        if not 0.0 < share <= 1.0:
            raise ValueError(f"share must be in (0, 1], got {share!r}")
        if not (is_finite_number(byte_time_s) and byte_time_s > 0.0):
            raise ValueError(f"byte_time_s must be > 0, got {byte_time_s!r}")
        self.share = share
        self.byte_time_s = byte_time_s
        self.ready_at = -math.inf   # s: the earliest start of the next frame
        self.bytes_total = 0        # every byte spent, for utilisation
        self.writes_total = 0

    def ready(self, now_s: float) -> bool:
        return now_s >= self.ready_at

    def spend(self, n: int, now_s: float) -> None:
        """n bytes written at now_s. A write before ready_at (the caller ignored the budget) is
        counted as if it had waited, so the budget still holds on average."""
        start = max(now_s, self.ready_at)
        self.ready_at = start + n * self.byte_time_s / self.share
        self.bytes_total += n
        self.writes_total += 1

    def write(self, now_s: float, produce) -> bytes:
        """`produce()`'s bytes, charged to the budget, if a write may start now; else b"" (and
        `produce` is not called, so nothing leaves its slot)."""
        if not self.ready(now_s):
            return b""
        data = produce()
        if data:
            self.spend(len(data), now_s)
        return data

    def utilisation(self, bytes_sent: int, elapsed_s: float) -> float:
        """Fraction of the line that bytes_sent occupied over elapsed_s."""
        return bytes_sent * self.byte_time_s / elapsed_s if elapsed_s > 0 else 0.0


class LatestSlots(Generic[K, V]):
    """Latest value per key; `pop_oldest` returns the key that has waited longest."""

    def __init__(self) -> None:
        self._slots: dict[K, list] = {}  # key -> [since_s, tie-break, value]
        self._counter = itertools.count()

    def put(self, key: K, value: V, now_s: float) -> None:
        """Newest value wins; a key already waiting keeps its place in line."""
        slot = self._slots.get(key)
        if slot is None:
            self._slots[key] = [now_s, next(self._counter), value]
        else:
            slot[2] = value

    def rank(self, key: K) -> tuple[float, int] | None:
        slot = self._slots.get(key)
        return None if slot is None else (slot[0], slot[1])

    def get(self, key: K) -> V | None:
        slot = self._slots.get(key)
        return None if slot is None else slot[2]

    def remove(self, key: K) -> V | None:
        slot = self._slots.pop(key, None)
        return None if slot is None else slot[2]

    def peek_oldest(self) -> tuple[K, V, float] | None:
        if not self._slots:
            return None
        if len(self._slots) == 1:
            key = next(iter(self._slots))  # what min() returns for one key
        else:
            key = min(self._slots, key=lambda k: (self._slots[k][0], self._slots[k][1]))
        since, _, value = self._slots[key]
        return key, value, since

    def pop_oldest(self) -> tuple[K, V, float] | None:
        """(key, value, waiting since) of the longest-waiting key, removed; None if empty."""
        oldest = self.peek_oldest()
        if oldest is not None:
            del self._slots[oldest[0]]
        return oldest

    def __len__(self) -> int:
        return len(self._slots)

    def __contains__(self, key: object) -> bool:
        return key in self._slots

    def __iter__(self) -> Iterator[K]:
        return iter(list(self._slots))


_STALE = object()  # a CommandBook cache entry that is to be computed again


@dataclass
class _Written:
    message: object       # the SET_* / STOP message
    since_s: float        # when its value started waiting (kept when it is made pending again)
    sent_at_s: float
    seq: int | None       # frame seq, None where the link has no acknowledgements
    acked: bool


class CommandBook:
    """Layer commands of one device: pending slots plus what was written, in write order.

    Keys are `layer_key`s (channel, layer); "stop" and channel 0xFF keys overlap others, see
    devices.messages.overrides/touches. Invariants: every written command was set no later than
    any pending one (the writer takes the oldest), and a pending command that must follow
    another pending one it touches has waited less than it.
    """

    def __init__(self) -> None:
        self.slots: LatestSlots[tuple[int, str], object] = LatestSlots()
        self.written: dict[tuple[int, str], _Written] = {}  # insertion order = write order
        self._oldest_unacked: float | None | object = _STALE
        self._has: dict[tuple[int, str], object] = {}  # key -> _device_has(key), for the current `written`

    def set(self, message, now_s: float) -> bool:
        """The newest value of one layer. Returns whether it changed between nothing waiting and
        something waiting (DeviceSession.set tells its driver from that whether to poll)."""
        if not isinstance(message, SET_MESSAGES):
            raise TypeError(f"not a SET_* or STOP message: {message!r}")
        key = message.layer_key
        waiting = self.slots._slots
        waited = bool(waiting)
        if len(waiting) <= (key in waiting):  # no other key waits (most sets): none touches this one
            has = self._device_has(key)
            if has is message or has == message:
                waiting.pop(key, None)  # the device already shows it: a waiting older value is moot
            else:
                self.slots.put(key, message, now_s)
            return bool(waiting) != waited
        touching = [k for k in waiting if k != key and touches(k, key)]  # their order with this one matters
        if not touching and self._device_has(key) == message:
            self.slots.remove(key)
            return bool(waiting) != waited
        # overrides implies touches, so only a touching key can be dropped or reorder this one
        for k in touching:
            if overrides(key, k):
                self.slots.remove(k)  # e.g. STOP c drops the waiting layers of c
        rank = self.slots.rank(key)
        if rank is not None and any(k in self.slots and self.slots.rank(k) > rank for k in touching):
            # it must now go after a touching command set meanwhile: line up anew
            self.slots.remove(key)
        self.slots.put(key, message, now_s)
        return not waited

    def _device_has(self, key: tuple[int, str]):
        """The value the device has on `key` as far as the host knows, else None."""
        # asked at every set, a function of `written` alone: kept until it changes (here only)
        has = self._has.get(key, _STALE)
        if has is not _STALE:
            return has
        has = None
        for k in reversed(self.written):
            if k == key:  # touches and overrides itself
                has = as_seen_by(self.written[k].message, key)
                break
            if touches(k, key):
                has = as_seen_by(self.written[k].message, key) if overrides(k, key) else None
                break
        self._has[key] = has
        return has

    def pop_next(self):
        """(key, message, since) of the command to write now, or None."""
        return self.slots.pop_oldest()

    def mark_written(self, key, message, since_s: float, now_s: float, seq: int | None = None) -> None:
        self._oldest_unacked = _STALE
        self._has.clear()
        for k, entry in list(self.written.items()):
            if overrides(key, k):
                del self.written[k]
            elif seq is not None and entry.seq == seq:
                entry.seq = -1  # seq wrapped before its ACK came: only the ACK timeout can clear it now
        self.written[key] = _Written(message, since_s, now_s, seq, acked=seq is None)

    def mark_acked(self, seq: int) -> None:
        for entry in self.written.values():
            if entry.seq == seq and not entry.acked:
                entry.acked = True
                self._oldest_unacked = _STALE
                return

    def oldest_unacked_at(self) -> float | None:
        # asked at every poll; cached until `written` or an entry's `acked` changes (here only)
        if self._oldest_unacked is _STALE:
            times = [e.sent_at_s for e in self.written.values() if not e.acked]
            self._oldest_unacked = min(times) if times else None
        return self._oldest_unacked

    def requeue_all(self) -> int:
        """Everything written becomes pending again (after a reconnect, §4.4)."""
        return self._requeue(list(self.written))

    def requeue_unacked(self) -> int:
        """The oldest unacknowledged command and everything written after it become pending
        again, so a resent command cannot undo a newer one it touches."""
        keys = list(self.written)
        first = next((i for i, k in enumerate(keys) if not self.written[k].acked), None)
        return 0 if first is None else self._requeue(keys[first:])

    def _requeue(self, keys: list) -> int:
        self._oldest_unacked = _STALE
        self._has.clear()
        newer = list(self.slots)  # every waiting value was set after every written one
        count = 0
        for key in keys:
            entry = self.written.pop(key)
            if any(overrides(k, key) for k in newer):
                continue  # a newer value for it waits already
            # its original since puts it before every newer pending value, in write order
            self.slots.put(key, entry.message, entry.since_s)
            count += 1
        return count

    @property
    def pending(self) -> int:
        return len(self.slots._slots)  # asked at every poll: without LatestSlots.__len__
