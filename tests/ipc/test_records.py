"""The records between the processes (server/ipc/records.py) against the pinned bytes
(tests/vectors/ipc_records.json, first written by the code before the records were typed), and
the channels' refusals."""

import json
from pathlib import Path

import msgpack
import pytest

from server import ipc
from server.ipc.records import (CHANNELS, CUES, FROM_AUDIO_WORKER, FROM_DEVICE_HOST, FROM_LOOP, FROM_TRACKER_HOST,
                                TO_AUDIO_WORKER, TO_DEVICE_HOST, TO_LOOP, TO_TRACKER_HOST, BadRecord, Cues, Input, Malformed, Stop, TrackerSample)
from tests.ipc import sent
from tests.vectors import make_ipc_vectors

VECTORS = json.loads((Path(__file__).parents[1] / "vectors" / "ipc_records.json").read_text())["channels"]
CHANNEL_OF = {"hub_to_loop": TO_LOOP, "loop_to_hub": FROM_LOOP, "cue_channel": CUES,
              "hub_to_device_host": TO_DEVICE_HOST, "device_host_to_hub": FROM_DEVICE_HOST,
              "hub_to_tracker_host": TO_TRACKER_HOST, "tracker_host_to_hub": FROM_TRACKER_HOST,
              "device_host_to_audio_worker": TO_AUDIO_WORKER, "audio_worker_to_device_host": FROM_AUDIO_WORKER}
TYPED = make_ipc_vectors.typed_records()


def test_the_records_are_built_to_the_pinned_bytes():
    """Today's builders (the loop's state, scene and scenario records included, and the /ws state
    message the hub makes of a state record) give the bytes the untyped code gave."""
    assert make_ipc_vectors.records() == VECTORS


@pytest.mark.parametrize("channel_name,name", [(c, n) for c, named in TYPED.items() for n in named])
def test_each_vector_decodes_to_its_record_and_back(channel_name, name):
    data = bytes.fromhex(VECTORS[channel_name][name])
    record = ipc.unpack(data, CHANNEL_OF[channel_name])
    assert record == TYPED[channel_name][name]
    assert type(record) is type(TYPED[channel_name][name])
    assert ipc.pack(record) == data


def test_every_record_of_every_channel_has_a_vector():
    assert set(CHANNEL_OF.values()) == set(CHANNELS)
    for channel_name, channel in CHANNEL_OF.items():
        assert {type(r) for r in TYPED[channel_name].values()} == set(channel.records), channel.name


def test_a_tracker_samples_optional_tail_goes_out_whole_or_not_at_all():
    short = TrackerSample(1, 2, 3.0, [0.0, 0.0, 0.0], None, 9)
    assert short.to_array() == ["tracker", 1, 2, 3.0, [0.0, 0.0, 0.0], None, 9]
    assert TrackerSample(1, 2, 3.0, [0.0, 0.0, 0.0], None, 9, ttl_ms=5.0).to_array()[-3:] == [None, None, 5.0]
    with pytest.raises(BadRecord, match="hub → loop: the 'tracker' record has 9 fields"):
        TO_LOOP.decode(["tracker", 1, 2, 3.0, [0.0, 0.0, 0.0], None, 9, "point"])


@pytest.mark.parametrize("array,match", [
    (["nonsense", 1], "unknown record 'nonsense'"),
    (["state", {"tick": 1}], "unknown record 'state'"),  # a loop → hub record on the hub → loop channel
    ([], "not a record"),
    ("stop", "not a record"),
    ([7], "unknown record 7"),
    (["input", 1], "the 'input' record has 4 fields"),
    (["stop", 1], "the 'stop' record has 0 fields"),
])
def test_a_record_that_is_none_of_the_channels_is_refused_by_name(array, match):
    with pytest.raises(BadRecord, match=match):
        TO_LOOP.decode(array)


@pytest.mark.parametrize("array", [
    ["cues", 1, 2.5, []], ["cues", 1, 2, {}], ["cues", 1, 2, [], {"thumb": "x"}], ["alive", 1], ["alive", 1, 2.5],
])
def test_the_cue_channel_checks_its_types(array):
    with pytest.raises(BadRecord):
        CUES.decode(array)


def test_a_bad_record_in_a_drain_is_handed_on_as_malformed_and_the_rest_arrive():
    ours, theirs = ipc.channel_pair()
    with ours, theirs:
        ipc.send_record(theirs, Input(1, "a", "down"))
        theirs.send(msgpack.packb(["nonsense"]))
        theirs.send(b"\xc1")  # not msgpack
        ipc.send_record(theirs, Stop())
        got = ipc.drain(ours, TO_LOOP)
    assert got[0] == Input(1, "a", "down") and got[-1] == Stop()
    assert [type(r) for r in got[1:3]] == [Malformed, Malformed]
    assert "unknown record 'nonsense'" in got[1].error and "not msgpack" in got[2].error


def test_a_peer_that_exits_with_our_records_unread_still_delivers_its_last_records():
    """Linux reports the reset before the records the peer sent last: they arrive, then the close."""
    ours, theirs = ipc.channel_pair()
    with ours:
        ipc.send_record(ours, Stop())  # never read by the peer
        ipc.send_record(theirs, Input(1, "a", "down"))
        ipc.send_record(theirs, Input(2, "a", "up"))
        theirs.close()
        ours.setblocking(False)
        assert ipc.drain(ours, TO_LOOP) == [Input(1, "a", "down"), Input(2, "a", "up")]
        with pytest.raises(ipc.PeerClosed):
            ipc.drain(ours, TO_LOOP)


def test_records_are_frozen_and_slotted():
    record = Cues(1, 2, [])
    with pytest.raises(AttributeError):
        record.tick = 3
    assert not hasattr(record, "__dict__")


def test_the_loop_reports_a_bad_record_from_the_hub_and_ticks_on():
    from scenarios.contact_angle import ContactAngle
    from server.loop.tick import Loop
    from server.loop.simulation import Simulation

    core = Loop(Simulation(ContactAngle()))
    out = core.tick([Malformed("hub → loop: unknown record 'teleport'"), Input(1, "space", "press")], 0)
    (log,) = [sent(r) for r in out.records]
    assert log[:2] == ["log", "error"] and "unknown record 'teleport'" in log[2]
    assert out.state is not None and [e["key"] for e in out.state.view["events"]] == ["space"], "the next record applies"
