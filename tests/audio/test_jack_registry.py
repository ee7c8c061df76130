"""JACK's server registry (devices/audio/jack_server.py): the slots of servers whose process is
gone are cleared, those of live ones kept (on a copy of the registry's layout, not the machine's)."""

import os
import subprocess
import sys

from devices.audio.jack_server import _SLOT_BYTES, _SLOTS, _SLOTS_AT, free_dead_server_slots


def slot(pid: int, name: str) -> bytes:
    raw = pid.to_bytes(4, "little", signed=True) + f"jack-0:{name}:".encode()
    return raw + bytes(_SLOT_BYTES - len(raw))


def test_dead_servers_slots_are_freed_and_live_ones_kept(tmp_path):
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()  # reaped: its pid names no process now
    slots = [slot(gone.pid, "viestac-gone"), slot(os.getpid(), "viestac-alive")]
    slots += [bytes(_SLOT_BYTES)] * (_SLOTS - len(slots))
    registry = tmp_path / "jack-shm-registry"
    registry.write_bytes(b"KCAJ" + bytes(_SLOTS_AT - 4) + b"".join(slots) + bytes(4096))
    assert free_dead_server_slots(str(registry)) == ["jack-0:viestac-gone:"]
    data = registry.read_bytes()
    assert data[_SLOTS_AT:_SLOTS_AT + _SLOT_BYTES] == bytes(_SLOT_BYTES)
    assert data[_SLOTS_AT + _SLOT_BYTES:_SLOTS_AT + 2 * _SLOT_BYTES] == slots[1]
    assert free_dead_server_slots(str(tmp_path / "none")) == []
