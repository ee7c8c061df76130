"""DeviceSession (docs/device-protocol.md §4–§6) against an in-memory device on simulated time:
bytes in, events and bytes out; no ports, no sleeps."""

import bisect
from dataclasses import replace

import pytest
from hypothesis import given
from hypothesis import strategies as st

from devices import messages as m
from devices.simulated_link import SimulatedLink
from tests.devices.fake_device import FERROVIBE, FINGERTAC, FakeDevice
from devices.framing import FrameDecoder, encode_frame
from devices.messages import ErrorCode, SetPattern, SetTemperature, SetTilt, Stop
from devices.protocol import (Acked, DeviceErrorReported, FrameRejected, DeviceSession, Identified, Pong,
                              StatusChanged)

EVERYTHING = replace(FINGERTAC, caps=m.Caps(0x3F), model="testrig")  # 2 channels, every layer


def link(identity=FINGERTAC, **kwargs) -> SimulatedLink:
    return SimulatedLink(DeviceSession(), FakeDevice(identity), **kwargs)


def events(sim: SimulatedLink, kind) -> list:
    return [(t, e) for t, e in sim.events if isinstance(e, kind)]


def statuses(sim: SimulatedLink) -> list[str]:
    return [e.new for _, e in events(sim, StatusChanged)]


def frame(message, seq=0) -> bytes:
    return encode_frame(message.TYPE, seq, message.pack())


# ---- handshake ------------------------------------------------------------------------------

def test_nothing_happens_before_the_port_opens():
    host = DeviceSession()
    host.set(SetTilt(0, 9000, 100), 0.0)
    assert host.poll(0.0) == (b"", None)
    assert host.status == "disconnected" and host.events_received() == []


def test_handshake_flush_hello_identify_connected():
    sim = link(FERROVIBE)
    sim.plug()
    sim.run_until(0.05)
    first = sim.writes[0][1]
    assert first == b"\x00" + frame(m.Hello(1), 0)  # §4.1: one 0x00, then HELLO
    assert statuses(sim) == ["handshaking", "connected"]
    assert [e.identity for _, e in events(sim, Identified)] == [FERROVIBE]
    assert sim.host.identity == FERROVIBE
    assert sim.host.counters["frames_out"] >= 2 and sim.host.counters["bytes_out"] == sum(len(b) for _, b in sim.writes)


def test_hello_is_retried_every_250_ms_until_identify():
    sim = link()
    sim.device.silent = True
    sim.plug()
    sim.run_until(1.1)
    hellos = [t for t, x in sim.written_messages() if isinstance(x, m.Hello)]
    assert hellos == pytest.approx([0.0, 0.25, 0.5, 0.75, 1.0])  # at most 4 per second, for ever
    assert sim.host.status == "handshaking"
    sim.device.silent = False
    sim.run_until(1.3)
    assert sim.host.status == "connected"
    assert not [t for t, x in sim.written_messages() if isinstance(x, m.Hello) and t > 1.26]


def test_ping_every_500_ms_gives_the_round_trip_time():
    sim = link(latency_s=0.004)
    sim.plug()
    sim.run_until(2.2)
    pings = [t for t, x in sim.written_messages() if isinstance(x, m.Ping)]
    assert len(pings) == 5 and all(b - a == pytest.approx(0.5) for a, b in zip(pings, pings[1:]))
    tokens = [x.token for _, x in sim.written_messages() if isinstance(x, m.Ping)]
    assert len(set(tokens)) == len(tokens)
    rtts = [e.rtt_s for _, e in events(sim, Pong)]
    # 2 × 4 ms latency + PING and PONG (10 B each) on the wire at 86.8 µs per byte
    assert rtts == pytest.approx([0.008 + 20 * 86.8e-6] * 5)
    assert sim.host.rtt_s == rtts[-1]


def test_silence_makes_the_device_unresponsive_and_a_frame_brings_it_back():
    sim = link(FERROVIBE)
    sim.set(SetTilt(0xFF, 9000, 100))
    sim.plug()
    sim.run_until(0.1)
    sim.device.silent = True
    t_silent = sim.t
    sim.run_until(3.0)
    (t_unresponsive, change), = [(t, e) for t, e in events(sim, StatusChanged) if e.new == "unresponsive"]
    last_frame = max(t for t, e in sim.events if isinstance(e, (Pong, Acked, Identified)) and t <= t_silent)
    assert t_unresponsive == pytest.approx(last_frame + 1.5)  # poll() woke up for the deadline
    pings_while_silent = [t for t, x in sim.written_messages() if isinstance(x, m.Ping) and t > t_unresponsive]
    assert len(pings_while_silent) >= 2  # §4.3: keeps pinging
    sim.device.power_cycle()  # what it shows is gone, as after a reset behind an open port
    sim.device.silent = False
    sim.run_until(3.6)
    assert statuses(sim)[-2:] == ["unresponsive", "connected"]
    assert sim.device.layer(0, "tilt") == SetTilt(0, 9000, 100)  # every layer sent again


def test_bad_version_from_error():
    sim = SimulatedLink(DeviceSession(), FakeDevice(FINGERTAC, version=2))
    sim.plug()
    sim.run_until(1.0)
    assert sim.host.status == "bad_version"
    assert [e.code for _, e in events(sim, DeviceErrorReported)] == [ErrorCode.BAD_VERSION]
    assert len([x for _, x in sim.written_messages() if isinstance(x, m.Hello)]) == 1  # no more HELLOs
    assert "Hello" in events(sim, DeviceErrorReported)[0][1].message_repr


def test_bad_version_from_identify_and_a_new_connection_starts_over():
    sim = link(replace(FINGERTAC, version=2))
    sim.plug()
    sim.run_until(0.5)
    assert sim.host.status == "bad_version" and sim.host.identity is None
    assert events(sim, Identified) == []
    sim.unplug()
    sim.device.identity = FINGERTAC
    sim.plug()
    sim.run_until(1.0)
    assert statuses(sim) == ["handshaking", "bad_version", "disconnected", "handshaking", "connected"]


# ---- commands -----------------------------------------------------------------------------------

def test_commands_set_before_the_port_opens_are_sent_after_it():
    sim = link(FERROVIBE)
    sim.set(SetTilt(0, 9000, 100))
    sim.set(SetPattern.pulse(0, 50, 200, 100))
    sim.plug()
    sim.run_until(0.05)
    assert sim.device.layer(0, "tilt") == SetTilt(0, 9000, 100)
    assert sim.device.layer(0, "pattern") == SetPattern.pulse(0, 50, 200, 100)
    acked = [e.message for _, e in events(sim, Acked)]
    assert acked == [SetTilt(0, 9000, 100), SetPattern.pulse(0, 50, 200, 100)]  # oldest first
    assert all(0 < e.latency_s < 0.01 for _, e in events(sim, Acked))


def test_a_value_the_device_has_is_not_resent():
    sim = link(FERROVIBE)
    sim.plug()
    sim.run_until(0.05)
    for i in range(100):
        sim.set(SetTilt(0, 9000, 100))
        sim.run_until(0.05 + i * 0.001)
    commands = [x for _, x in sim.written_messages() if isinstance(x, SetTilt)]
    assert commands == [SetTilt(0, 9000, 100)]


def test_stop_is_one_frame_and_off_values_after_it_are_not_sent():
    sim = link()
    sim.plug()
    sim.set(SetPattern.continuous(0xFF, 80))
    sim.run_until(0.05)
    sim.set(Stop(0xFF))
    sim.run_until(0.1)
    sim.set(Stop(0xFF))
    sim.set(SetPattern.off(0xFF))
    sim.run_until(0.2)
    commands = [x for _, x in sim.written_messages() if isinstance(x, m.SET_MESSAGES)]
    assert commands == [SetPattern.continuous(0xFF, 80), Stop(0xFF)]
    assert sim.device.layer(1, "pattern") == SetPattern.off(1)


def test_latest_wins_within_half_the_link():
    """A value set every 1 ms for 10 s: the link stays within its share and the newest value
    always leaves within 20 ms of being set."""
    sim = link()
    sim.plug()
    sets = []
    for i in range(10_000):
        sim.run_until(i * 1e-3)
        value = SetPattern.pulse(0, 10 + (i % 997) / 10, 200, 100)
        sim.set(value)
        sets.append((sim.t, value))
    sim.run_until(10.0)
    sent = sum(len(b) for t, b in sim.writes if t < 10.0)
    # 50 % of 11,520 B/s for 10 s, plus the one frame whose budget slot ends after 10 s
    # (86.8 µs is 11,520.7 B/s, and §5 charges each frame's time after its start)
    assert sent <= 0.5 * 11_520 * 10 + 19
    budget = sim.host.budget
    assert budget.bytes_total * budget.byte_time_s <= 0.5 * budget.ready_at + 1e-9  # exact §5 invariant
    sim.run_until(10.1)
    written = [(t, x) for t, x in sim.written_messages() if isinstance(x, SetPattern)]
    times = [t for t, _ in written]
    worst = max(times[bisect.bisect_left(times, t)] - t for t, _ in sets)
    assert worst <= 0.020
    assert sim.device.layer(0, "pattern") == sets[-1][1]
    assert len(written) < len(sets) / 2  # coalesced, not queued


def test_no_layer_starves():
    """Six layers changing every ms share the link; each one's newest value leaves within 20 ms."""
    sim = link(EVERYTHING)
    sim.plug()
    makers = [lambda i, c=c: SetPattern.pulse(c, 10 + i % 50, 100, 100) for c in (0, 1)]
    makers += [lambda i, c=c: SetTilt(c, (i * 100) % 36000, 50) for c in (0, 1)]
    makers += [lambda i: SetTemperature(0, 3000 + i % 100), lambda i: m.SetFriction(1, i % 1000)]
    sets = []
    for i in range(2000):
        sim.run_until(i * 1e-3)
        for make in makers:
            value = make(i)
            sim.set(value)
            sets.append((sim.t, value))
    sim.run_until(2.1)
    written = sim.written_messages()
    for key in {v.layer_key for _, v in sets}:
        times = [t for t, x in written if getattr(x, "layer_key", None) == key]
        worst = max(times[bisect.bisect_left(times, t)] - t for t, v in sets if v.layer_key == key)
        assert worst <= 0.020, key
    for c in (0, 1):
        assert sim.device.layer(c, "tilt") == [v for _, v in sets if v.layer_key == (c, "tilt")][-1]


def test_every_layer_is_sent_again_after_a_reconnect():
    sim = link(FERROVIBE)
    sim.plug()
    sim.set(SetTilt(0, 9000, 100))
    sim.set(SetPattern.continuous(0, 40))
    sim.run_until(0.1)
    sim.unplug("read failed")
    sim.device.power_cycle()
    sim.set(SetTilt(0, 18000, 100))  # changed while unplugged
    sim.run_until(0.6)
    assert sim.host.poll(sim.t) == (b"", None)
    sim.plug()
    sim.run_until(0.7)
    assert statuses(sim) == ["handshaking", "connected", "disconnected", "handshaking", "connected"]
    assert sim.device.layer(0, "tilt") == SetTilt(0, 18000, 100)
    assert sim.device.layer(0, "pattern") == SetPattern.continuous(0, 40)


# ---- ACK / ERROR attribution and recovery ------------------------------------------------------

def test_errors_are_attributed_to_their_command_and_not_resent():
    sim = link(FINGERTAC)  # no tilt capability
    sim.plug()
    sim.set(SetTilt(0, 9000, 100))
    sim.set(SetPattern.pulse(5, 50, 200, 100))  # channel 5 does not exist
    sim.run_until(2.0)
    reported = [e for _, e in events(sim, DeviceErrorReported)]
    assert [(e.code, e.message_repr) for e in reported] == [
        (ErrorCode.UNSUPPORTED, repr(SetTilt(0, 9000, 100))),
        (ErrorCode.BAD_CHANNEL, repr(SetPattern.pulse(5, 50, 200, 100)))]
    assert sim.host.counters["device_errors"] == 2 and sim.host.counters["resent"] == 0
    assert len([x for _, x in sim.written_messages() if isinstance(x, SetTilt)]) == 1


def test_acks_carry_the_latency_from_write_to_ack():
    sim = link(FERROVIBE, latency_s=0.005)
    sim.plug()
    sim.run_until(0.1)
    sim.set(SetTilt(0, 9000, 100))
    sim.run_until(0.2)
    (t, ack), = events(sim, Acked)
    write_t = [t for t, x in sim.written_messages() if isinstance(x, SetTilt)][0]
    assert ack.latency_s == pytest.approx(t - write_t)
    assert ack.latency_s == pytest.approx(0.010 + (10 + 7) * 86.8e-6)  # SET_TILT 10 B, ACK 7 B
    assert sim.host.counters["acks"] == 1


def corrupt_writes(predicate):
    def to_device(data: bytes) -> bytes:
        if predicate(data):
            out = bytearray(data)
            out[4] ^= 0x40  # a data byte (not a COBS code): the device sees a bad CRC
            return bytes(out)
        return data
    return to_device


def test_a_frame_the_device_could_not_read_is_resent():
    hit = []
    sim = link(FERROVIBE, to_device=corrupt_writes(lambda d: d[1] == m.SetTilt.TYPE and not hit and not hit.append(1)))
    sim.plug()
    sim.run_until(0.05)
    sim.set(SetTilt(0, 9000, 100))
    sim.run_until(0.2)
    assert [(e.ref_seq, e.code, e.message_repr) for _, e in events(sim, DeviceErrorReported)] == [
        (0xFF, ErrorCode.BAD_CRC, None)]
    assert sim.host.counters["resent"] == 1
    assert sim.device.layer(0, "tilt") == SetTilt(0, 9000, 100)


def test_a_lost_frame_is_resent_after_the_ack_timeout():
    dropped = []
    sim = link(FERROVIBE, to_device=lambda d: b"" if (d[1] == m.Stop.TYPE and not dropped and
                                                      not dropped.append(1)) else d)
    sim.plug()
    sim.set(SetTilt(0, 9000, 100))
    sim.run_until(0.05)
    sim.set(Stop(0))
    sim.run_until(0.4)
    assert sim.device.layer(0, "tilt") == SetTilt(0, 9000, 100)  # the STOP never arrived
    sim.run_until(0.7)
    assert sim.device.layer(0, "tilt") == SetTilt.flat(0)
    assert sim.host.counters["resent"] == 1


# ---- what the device sends that is wrong -------------------------------------------------------

def test_rejected_frames_are_counted_and_reported():
    host = DeviceSession()
    host.connection_made(0.0)
    host.poll(0.0)
    host.receive_data(b"\x55" * 70 + b"\x00" + b"\x05\x11\x00" + frame(m.SetTilt(0, 1, 1)) +
                      encode_frame(0x7E, 0) + encode_frame(0x83, 1, b"\x01\x02"), 0.01)
    kinds = [e.error.kind for e in host.events_received() if isinstance(e, FrameRejected)]
    assert kinds == ["too_long", "framing", "unknown_type", "unknown_type", "bad_length"]
    assert {k: host.counters[k] for k in ("too_long", "framing", "unknown_type", "bad_length")} == {
        "too_long": 1, "framing": 1, "unknown_type": 2, "bad_length": 1}
    assert host.status == "handshaking"
    host.receive_data(frame(FINGERTAC), 0.02)  # a good frame after all that still counts
    assert host.status == "connected"


def test_an_ack_for_an_unknown_seq_is_still_an_event():
    host = DeviceSession()
    host.connection_made(0.0)
    host.receive_data(frame(m.Ack(200)), 0.01)
    assert [e for e in host.events_received() if isinstance(e, Acked)] == [Acked(200, None, None)]


def test_poll_tells_when_to_come_back():
    host = DeviceSession()
    host.connection_made(0.0)
    data, wake = host.poll(0.0)
    assert data.startswith(b"\x00") and len(data) == 8  # flush + HELLO
    assert wake == pytest.approx(0.25)  # nothing else to send before the next HELLO
    host.set(SetTilt(0, 1, 1), 0.0005)
    assert host.poll(0.0005) == (b"", pytest.approx(8 * 86.8e-6 / 0.5))  # the budget says wait
    assert len(host.poll(0.0014)[0]) == 10
    host.receive_data(frame(FINGERTAC), 0.002)
    assert host.poll(0.002) == (b"", pytest.approx(0.0014 + 10 * 86.8e-6 / 0.5))
    data, wake = host.poll(0.004)
    (ping,) = FrameDecoder().feed(data)
    assert m.unpack(ping.type, ping.payload) == m.Ping(1)  # the first PING as soon as connected
    assert wake == pytest.approx(0.0014 + 0.5)  # the ACK timeout of the unanswered SET_TILT
    host.receive_data(frame(m.Ack(1)), 0.005)
    assert host.poll(0.005) == (b"", pytest.approx(0.004 + 0.5))  # the next PING


@given(st.lists(st.binary(max_size=100), max_size=10))
def test_arbitrary_bytes_never_raise_and_a_good_frame_after_them_counts(chunks):
    host = DeviceSession()
    host.connection_made(0.0)
    host.set(SetTilt(0, 1, 1), 0.0)
    t = 0.0
    for chunk in chunks:
        t += 0.01
        host.receive_data(chunk, t)
        host.poll(t)
    host.receive_data(b"\x00" + frame(FERROVIBE), t)
    host.events_received()
    assert host.identity == FERROVIBE
    data, wake = host.poll(t + 1.0)
    assert wake is None or wake >= t + 1.0
