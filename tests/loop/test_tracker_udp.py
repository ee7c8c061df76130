"""The tracker UDP port: datagrams parsed like /ws tracker messages, bad ones answered and counted,
at most MAX_PER_TICK read per tick; over a real UDP socket on localhost."""

from __future__ import annotations

import json
import socket
import time

import msgpack
import pytest

from server.loop import tracker_udp
from server.loop.tracker_udp import MAX_PER_TICK, TrackerPort, parse_datagram
from server.wire.codec import WireError
from server.ipc.records import TrackerSample
from tests.ipc import sent


def test_msgpack_and_json_datagrams_become_the_loops_tracker_records():
    sample = {"type": "tracker", "seq": 7, "t": 12.5, "pos": [0.1, 0.2, 1.0]}
    assert parse_datagram(msgpack.packb(sample), "udp:h:1", 99) == TrackerSample("udp:h:1", 7, 12.5, [0.1, 0.2, 1.0], None, 99)
    with_quat = {**sample, "quat": [1, 0, 0, 0]}
    assert parse_datagram(json.dumps(with_quat).encode(), "udp:h:1", 5).quat == [1.0, 0.0, 0.0, 0.0]


@pytest.mark.parametrize("data, code", [
    (b"\xc1", "bad_encoding"),
    (b"{not json", "bad_encoding"),
    (b"{\xff\xfe}", "bad_encoding"),
    (json.dumps({"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0]}).encode(), "bad_message"),
    (b'{"type":"tracker","seq":1,"t":0,"pos":[NaN,0,0]}', "non_finite"),
    (msgpack.packb({"type": "input", "key": "space", "action": "down"}), "bad_message"),
    (msgpack.packb({"type": "teleport"}), "unknown_type"),
    (msgpack.packb([1, 2, 3]), "bad_message"),
])
def test_anything_but_a_valid_tracker_message_is_refused_with_the_ws_error_codes(data, code):
    with pytest.raises(WireError) as info:
        parse_datagram(data, "udp:h:1", 0)
    assert info.value.code == code and info.value.message


@pytest.fixture
def port():
    sock = tracker_udp.bind(("127.0.0.1", 0))
    yield TrackerPort(sock), sock.getsockname()
    sock.close()


def _drain_until(tracker_port: TrackerPort, count: int, now_ns: int = 1) -> list[list]:
    records = []
    for _ in range(1000):
        records += tracker_port.drain(now_ns)
        if len(records) >= count:
            break
        time.sleep(0.001)
    return records


def test_samples_sent_to_the_port_are_read_in_order_and_bad_ones_get_one_error_reply(port):
    tracker_port, address = port
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as bridge:
        bridge.settimeout(2.0)
        bridge.sendto(msgpack.packb({"type": "tracker", "seq": 1, "t": 0.0, "pos": [0, 0, 1]}), address)
        bridge.sendto(b'{"type":"tracker","seq":2}', address)
        bridge.sendto(json.dumps({"type": "tracker", "seq": 3, "t": 1.0, "pos": [0, 0.5, 1]}).encode(), address)
        records = _drain_until(tracker_port, 2, now_ns=42)
        me = "udp:127.0.0.1:%d" % bridge.getsockname()[1]
        assert [(r[1], r[2], r[4], r[6]) for r in map(sent, records)] == [(me, 1, [0.0, 0.0, 1.0], 42), (me, 3, [0.0, 0.5, 1.0], 42)]
        reply = json.loads(bridge.recv(2048))  # in the sender's format (JSON here)
        assert reply["type"] == "error" and reply["code"] == "bad_message" and "'t'" in reply["message"]
    assert (tracker_port.received, tracker_port.bad) == (2, 1)
    assert len(tracker_port.notices) == 1 and me in tracker_port.notices[0]


def test_a_flood_is_read_at_most_max_per_tick_at_a_time_and_nothing_is_lost(port):
    tracker_port, address = port
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as bridge:
        for seq in range(MAX_PER_TICK * 2 + 5):
            bridge.sendto(msgpack.packb({"type": "tracker", "seq": seq, "t": 0.0, "pos": [0, 0, 1]}), address)
        first = tracker_port.drain(0)
        assert len(first) == MAX_PER_TICK
        rest = _drain_until(tracker_port, MAX_PER_TICK + 5)
    assert [r[2] for r in map(sent, first + rest)] == list(range(MAX_PER_TICK * 2 + 5))


def test_binding_a_port_in_use_says_which_and_what_to_do(port):
    _, address = port
    with pytest.raises(OSError, match=r"tracker UDP port 127\.0\.0\.1:\d+.*--tracker-udp"):
        tracker_udp.bind(address)


# ---- issue 19: loopback only (the port has no authentication) -------------------------------------
@pytest.mark.parametrize("setting, host, expected", [
    ("auto", "127.0.0.1", ("127.0.0.1", 8001)),
    ("auto", "0.0.0.0", ("127.0.0.1", 8001)),      # serving on the LAN does not open the tracker port to it
    ("auto", "192.168.1.20", ("127.0.0.1", 8001)),
    ("9000", "0.0.0.0", ("127.0.0.1", 9000)),
    ("[::1]:9000", "127.0.0.1", ("::1", 9000)),
    ("localhost:9000", "127.0.0.1", ("localhost", 9000)),
    ("127.0.0.2:9000", "127.0.0.1", ("127.0.0.2", 9000)),
    ("off", "0.0.0.0", None),
])
def test_the_tracker_port_binds_to_loopback_whatever_the_http_host(setting, host, expected):
    from server.config import Settings
    assert Settings(host=host, port=8000, tracker_udp=setting).tracker_address() == expected


@pytest.mark.parametrize("setting", ["0.0.0.0:9000", "192.168.1.20:9000", "[::]:9000", "rig.local:9000"])
def test_a_non_loopback_tracker_address_is_refused_at_start(setting):
    from server.config import Settings
    with pytest.raises(ValueError, match="loopback only"):
        Settings(tracker_udp=setting)
    with pytest.raises(ValueError, match="loopback only"):
        tracker_udp.bind((setting.rpartition(":")[0].strip("[]"), 0))
