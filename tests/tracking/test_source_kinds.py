"""Tracker sources are kinds declared once (server/tracking/sources.py KINDS): `--tracker` is parsed
and the tracker host runs a source through its kind, with no per-kind branch anywhere else."""

import asyncio
import socket
from types import MappingProxyType

import msgpack
import pytest

from server.tracking import sources, store
from server.tracking.calibration import Calibration, leap_default
from server.tracking.tracker_host_process import Source
from server.tracking.source_kind import SourceKind, SourceSpec
from server.tracking.sources import KINDS, parse_spec, parse_specs


def test_the_three_kinds_and_their_names():
    assert list(KINDS) == ["leap", "replay", "scripted"]
    specs = parse_specs(["leap", "leap:ws://10.0.0.2:6437/v6.json", "scripted:tap"])
    assert [(s.name, s.kind) for s in specs] == [("leap", "leap"), ("leap2", "leap"), ("scripted", "scripted")]
    assert store.default_for("leap") == leap_default() and store.default_for("scripted") == Calibration()
    assert not KINDS["scripted"].filtered and KINDS["leap"].filtered


def test_an_unknown_kind_lists_every_kind_s_usage():
    with pytest.raises(ValueError, match=r"expected leap\[:URL\], replay:FILE\.csv\[:loop\|:once\] or scripted:NAME"):
        parse_spec("kinect:0")


def _still(points):
    async def run(source):
        source.health.connected, source.health.note = True, "running"
        for k in range(3):
            source.sample(points, k / 120.0, 1.0)
        source.health.connected, source.health.note = False, "done"
    return run


def test_a_new_kind_is_one_declaration_the_parser_and_the_tracker_host_use(monkeypatch):
    points = {"right.index.tip": (0.1, 0.2, 0.3)}
    still = SourceKind("still", "still:NAME", lambda rest, text: SourceSpec("still", "still", rest), _still(points),
                       filtered=False)
    monkeypatch.setattr(sources, "KINDS", MappingProxyType({**KINDS, "still": still}))
    spec = parse_spec("still:demo")
    assert spec == SourceSpec("still", "still", "demo")
    loop_port = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    loop_port.bind(("127.0.0.1", 0))
    loop_port.settimeout(2.0)
    source = Source(spec, Calibration(), loop_port.getsockname())
    asyncio.run(source.run())
    received = [msgpack.unpackb(loop_port.recv(8192)) for _ in range(source.sent)]
    loop_port.close()
    source.sock.close()
    assert source.sent == 3 and source.health.note == "done"
    assert all(m["type"] == "tracker" and m["pos"] == [0.1, 0.2, 0.3] for m in received)
