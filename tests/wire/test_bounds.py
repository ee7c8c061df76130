"""The protocol's bounds (issue 18): a tracker position outside the workspace and integers beyond
±(2^53 − 1) are `out_of_range` on /ws and on the tracker UDP port alike (both parse with
server.wire.messages.parse_client_message)."""

import json

import msgpack
import pytest

from server.core.workspace import WORKSPACE_HALF_EXTENT_M, clamp_to_workspace, in_workspace
from server.loop.tracker_udp import error_reply, parse_datagram
from server.wire.codec import WireError


@pytest.mark.parametrize("pos", [[0, 1e154, 0.5], [0, 1.35e154, 0.5], [0, 0, WORKSPACE_HALF_EXTENT_M * 1.0001]])
@pytest.mark.parametrize("fmt", ["msgpack", "json"])
def test_the_udp_port_refuses_a_position_outside_the_workspace(pos, fmt):
    body = {"type": "tracker", "seq": 1, "t": 0, "pos": pos}
    data = msgpack.packb(body) if fmt == "msgpack" else json.dumps(body).encode()
    with pytest.raises(WireError) as info:
        parse_datagram(data, "udp:127.0.0.1:9", 0)
    assert info.value.code == "out_of_range"
    reply = error_reply(data, info.value)
    decoded = msgpack.unpackb(reply) if fmt == "msgpack" else json.loads(reply)
    assert decoded["code"] == "out_of_range" and "pos" in decoded["message"]


def test_the_workspace_edge_is_inside():
    h = WORKSPACE_HALF_EXTENT_M
    record = parse_datagram(msgpack.packb({"type": "tracker", "seq": 1, "t": 0, "pos": [h, -h, h]}), "udp:x", 0)
    assert record.pos == [h, -h, h]
    assert in_workspace((h, -h, 0.0)) and not in_workspace((h + 1e-9, 0.0, 0.0))
    assert not in_workspace((float("nan"), 0.0, 0.0))
    assert clamp_to_workspace((1e308, -1e308, float("nan"))) == (h, -h, 0.0)


@pytest.mark.parametrize("seq", [2**53, 2**64 - 1, 1e300])
def test_integers_beyond_2_53_are_out_of_range(seq):
    with pytest.raises(WireError) as info:
        parse_datagram(msgpack.packb({"type": "tracker", "seq": seq, "t": 0, "pos": [0, 0, 0]}), "udp:x", 0)
    assert info.value.code == "out_of_range"
    ok = parse_datagram(msgpack.packb({"type": "tracker", "seq": 2**53 - 1, "t": 0, "pos": [0, 0, 0]}), "udp:x", 0)
    assert ok.seq == 2**53 - 1
