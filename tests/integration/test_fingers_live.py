"""Two fingers with the real server: a FerroVibe emulator on the index and a FingerTac emulator on
the thumb (`--finger`), tracker samples of a hand over the tracker UDP port (protocol v1.4).
The index's touch reaches only the index's device; a source that stops (ttl) turns it off."""

from __future__ import annotations

import socket
import time

import msgpack
import pytest

from devices.emulator import Emulator
from tests.live_server import get_json, start_server, stop_server
from tests.integration.test_server_ws import _on_dome

THUMB = "right.thumb.tip"
FREE = [0.0, 0.5, 1.3]


@pytest.fixture
def two_finger_server(tmp_path):
    emulators = {name: Emulator(model, link=tmp_path / name)
                 for name, model in (("index", "ferrovibe"), ("thumb", "fingertac"))}
    for emulator in emulators.values():
        emulator.start()
    proc, base = start_server("contact-angle", ["--device", f"index=ferrovibe@{tmp_path / 'index'}",
                                                "--device", f"thumb=fingertac@{tmp_path / 'thumb'}",
                                                "--finger", f"thumb={THUMB}"])
    try:
        yield emulators, base
    finally:
        stop_server(proc)
        for emulator in emulators.values():
            emulator.stop()


def wait_for(predicate, timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(what)
        time.sleep(0.01)


def tilted(emulator: Emulator, since_us: int = 0) -> bool:
    edges = [e for e in emulator.snapshot_edges() if e.t_us >= since_us]
    return bool(edges) and edges[-1].magnitude > 0


def active_edges(emulator: Emulator) -> list:
    return [e for e in emulator.snapshot_edges() if e.gate or e.mode != 0 or e.magnitude > 0]


def test_the_index_touch_cues_only_the_index_device_and_a_lost_source_turns_it_off(two_finger_server):
    emulators, base = two_finger_server
    assert {d["name"]: d["finger"] for d in get_json(base + "/api/devices")["devices"]} == {
        "index": "right.index.tip", "thumb": THUMB}
    host, port = get_json(base + "/api/health")["tracker_udp"].rsplit(":", 1)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)

    def send(seq: int, index, thumb) -> None:
        sock.sendto(msgpack.packb({"type": "tracker", "seq": seq, "t": time.monotonic() * 1e3, "pos": index,
                                   "points": {THUMB: thumb}, "ttl": 40}), (host.strip("[]"), int(port)))

    wait_for(lambda: get_json(base + "/api/devices")["devices"][0]["status"] == "connected"
             and get_json(base + "/api/devices")["devices"][1]["status"] == "connected", 5.0, "devices never connected")
    # the thumb touches the dome, the index is free: contact-angle cues the primary tool's devices only
    for seq in range(30):
        send(seq, FREE, _on_dome(20.0))
        time.sleep(0.01)
    assert not any(e.magnitude > 0 for e in emulators["index"].snapshot_edges())
    # the index touches: the index's FerroVibe tilts, the thumb's FingerTac stays off
    for seq in range(30, 60):
        send(seq, _on_dome(-30.0), FREE)
        time.sleep(0.01)
    wait_for(lambda: tilted(emulators["index"]), 2.0, "the index's device never tilted")
    assert active_edges(emulators["thumb"]) == [], "the thumb's device got the index's cue"
    # the source stops: its ttl (40 ms) passes, the index leaves contact, the FerroVibe goes flat
    last_sent_us = time.monotonic_ns() // 1000
    wait_for(lambda: not tilted(emulators["index"]), 2.0, "the lost source's cue stayed on")
    flat = next(e for e in emulators["index"].snapshot_edges() if e.t_us >= last_sent_us and e.magnitude == 0)
    assert flat.t_us - last_sent_us < 200_000, "off well within the ttl and the loop's 100 ms (slack: a busy machine)"
    state = get_json(base + "/api/state")
    assert state["tracking"]["lost"] and all(t["lost"] for t in state["tools"])
