"""Link budget, latest-wins slots and the command book (docs/device-protocol.md §4.4, §5)."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from devices import messages as m
from devices.link import CommandBook, LatestSlots, LinkBudget
from devices.messages import SetPattern, SetTemperature, SetTilt, Stop


def test_budget_spaces_frames_by_share():
    budget = LinkBudget()
    assert budget.ready(0.0)
    budget.spend(19, 1.0)  # the largest command, SET_PATTERN (§5)
    assert budget.ready_at == pytest.approx(1.0 + 19 * 86.8e-6 / 0.5)
    assert budget.ready_at - 1.0 == pytest.approx(3.3e-3, abs=0.01e-3)
    assert not budget.ready(1.003) and budget.ready(1.0033)
    budget.spend(10, budget.ready_at)
    assert budget.bytes_total == 29 and budget.writes_total == 2
    assert budget.utilisation(5760, 1.0) == pytest.approx(0.5, rel=1e-3)


def test_budget_counts_an_early_write_as_if_it_had_waited():
    budget = LinkBudget(share=1.0, byte_time_s=1e-3)
    budget.spend(10, 0.0)
    budget.spend(10, 0.001)  # too early: starts at 0.010
    assert budget.ready_at == pytest.approx(0.020)


@pytest.mark.parametrize("kwargs", [{"share": 0}, {"share": 1.5}, {"byte_time_s": 0}, {"byte_time_s": float("nan")}])
def test_budget_validates(kwargs):
    with pytest.raises(ValueError):
        LinkBudget(**kwargs)


def test_slots_latest_wins_oldest_first_and_overwrite_keeps_its_place():
    slots = LatestSlots()
    slots.put("a", 1, 0.0)
    slots.put("b", 1, 0.1)
    slots.put("a", 2, 0.2)  # newer value, same place in line
    slots.put("c", 1, 0.1)  # same time as b: insertion order breaks the tie
    assert len(slots) == 3 and slots.get("a") == 2
    assert [slots.pop_oldest() for _ in range(3)] == [("a", 2, 0.0), ("b", 1, 0.1), ("c", 1, 0.1)]
    assert slots.pop_oldest() is None


def test_a_fast_key_neither_starves_others_nor_is_starved():
    slots = LatestSlots()
    last_sent = {}
    t = 0.0
    for step in range(1000):
        t = step * 1e-3
        slots.put("fast", step, t)  # changes every ms
        if step % 7 == 0:
            slots.put(f"slow{step % 3}", step, t)
        if step % 3 == 0:  # the link takes one value every 3 ms
            key, value, since = slots.pop_oldest()
            assert t - since <= 0.012, (key, t, since)  # waits at most for the other keys
            last_sent[key] = value
    assert set(last_sent) == {"fast", "slow0", "slow1", "slow2"}


# ---- CommandBook ------------------------------------------------------------------------------

def drain(book: CommandBook, now: float = 1.0) -> list:
    out = []
    while (nxt := book.pop_next()) is not None:
        key, message, since = nxt
        book.mark_written(key, message, since, now)
        out.append(message)
    return out


def test_a_value_the_device_has_is_not_sent_again():
    book = CommandBook()
    book.set(SetTilt(0, 9000, 100), 0.0)
    assert drain(book) == [SetTilt(0, 9000, 100)]
    book.set(SetTilt(0, 9000, 100), 0.1)
    assert book.pending == 0
    book.set(SetTilt(0, 100, 100), 0.2)
    book.set(SetTilt(0, 9000, 100), 0.3)  # back to what the device has before anything left
    assert book.pending == 0


def test_stop_replaces_waiting_layers_and_later_sets_follow_it():
    book = CommandBook()
    book.set(SetPattern.pulse(0, 50, 200, 100), 0.0)
    book.set(SetTilt(0, 9000, 100), 0.0)
    book.set(SetTilt(1, 9000, 100), 0.0)
    book.set(Stop(0), 0.1)
    book.set(SetTilt(0, 100, 50), 0.2)
    assert drain(book) == [SetTilt(1, 9000, 100), Stop(0), SetTilt(0, 100, 50)]


def test_after_a_stop_off_values_are_known_but_temperature_is_not():
    book = CommandBook()
    book.set(Stop(0xFF), 0.0)
    drain(book)
    book.set(Stop(0xFF), 0.1)
    book.set(Stop(1), 0.1)
    book.set(SetPattern.off(0), 0.1)
    book.set(SetTilt.flat(1), 0.1)
    assert book.pending == 0
    book.set(SetTemperature(0, 0), 0.1)  # a STOP turns temperature "off", which is not 0 °C
    assert book.pending == 1


def test_broadcast_and_channel_values():
    book = CommandBook()
    book.set(SetPattern.continuous(0, 50), 0.0)
    book.set(SetPattern.off(0xFF), 0.1)  # replaces the waiting channel-0 value
    assert drain(book) == [SetPattern.off(0xFF)]
    book.set(SetPattern.off(1), 0.2)  # the broadcast set it already
    assert book.pending == 0
    book.set(SetPattern.continuous(1, 80), 0.3)
    drain(book)
    book.set(SetPattern.off(0xFF), 0.4)  # channel 1 differs now: not deduplicated
    assert book.pending == 1


def test_a_value_overwritten_after_a_touching_command_lines_up_behind_it():
    book = CommandBook()
    book.set(SetPattern.continuous(0xFF, 50), 0.0)
    book.set(Stop(0), 0.1)
    book.set(SetPattern.continuous(0xFF, 60), 0.2)  # newest: must reach channel 0 after the STOP
    assert drain(book) == [Stop(0), SetPattern.continuous(0xFF, 60)]


def test_requeue_all_keeps_write_order_and_newer_pending_values():
    book = CommandBook()
    for t, message in enumerate([Stop(0xFF), SetPattern.continuous(0, 40), SetTilt(0, 100, 10)]):
        book.set(message, float(t))
        drain(book, float(t))
    book.set(SetTilt(0, 200, 20), 5.0)
    assert book.requeue_all() == 2  # the old tilt is superseded by the waiting one
    assert drain(book) == [Stop(0xFF), SetPattern.continuous(0, 40), SetTilt(0, 200, 20)]


def test_requeue_unacked_resends_from_the_oldest_unacknowledged():
    book = CommandBook()
    for seq, message in enumerate([SetTilt(0, 100, 10), Stop(0), SetPattern.continuous(0, 40)]):
        book.set(message, float(seq))
        key, value, since = book.pop_next()
        book.mark_written(key, value, since, float(seq), seq)
    book.mark_acked(0)
    book.mark_acked(2)  # the STOP (seq 1) was lost; the pattern after it must go again too
    assert book.oldest_unacked_at() == 1.0
    assert book.requeue_unacked() == 2
    assert drain(book) == [Stop(0), SetPattern.continuous(0, 40)]
    assert book.requeue_unacked() == 0


def test_a_reused_seq_acknowledges_only_the_newest_frame():
    book = CommandBook()
    book.set(SetTilt(0, 100, 10), 0.0)
    key, value, since = book.pop_next()
    book.mark_written(key, value, since, 0.0, seq=7)  # its ACK is lost
    book.set(SetPattern.continuous(0, 40), 0.4)
    key, value, since = book.pop_next()
    book.mark_written(key, value, since, 0.4, seq=7)  # 256 frames later
    book.mark_acked(7)
    assert book.oldest_unacked_at() == 0.0  # the tilt still waits for its ACK timeout


def test_only_commands_go_in():
    with pytest.raises(TypeError):
        CommandBook().set(m.Ping(1), 0.0)


# ---- property: whatever the interleaving, the device ends where the commands say -----------

CHANNELS = 2


def apply(state: dict, message) -> None:
    """A device model: (channel, layer) -> value; STOP/absent = off (§2)."""
    for c in range(CHANNELS) if message.channel == 0xFF else [message.channel]:
        if isinstance(message, Stop):
            for layer in m.LAYERS:
                state.pop((c, layer), None)
        else:
            state[(c, message.layer_key[1])] = m.as_seen_by(message, (c, message.layer_key[1]))


commands = st.one_of(
    st.builds(SetPattern.continuous, st.sampled_from([0, 1, 0xFF]), st.integers(0, 2)),
    st.builds(SetTilt, st.sampled_from([0, 1, 0xFF]), st.just(0), st.integers(0, 2)),
    st.builds(SetTemperature, st.sampled_from([0, 1, 0xFF]), st.integers(0, 1)),
    st.builds(Stop, st.sampled_from([0, 1, 0xFF])),
)
steps = st.lists(st.one_of(commands, st.sampled_from(["write", "write", "power_cycle", "lose_unacked"])),
                 max_size=60)


@settings(max_examples=600)  # ~1 s; a 20,000-example run found nothing either
@given(steps)
def test_the_device_ends_in_the_state_the_commands_describe(script):
    book, wanted, device = CommandBook(), {}, {}
    seq = 0
    for t, step in enumerate(script):
        if step == "write":
            nxt = book.pop_next()
            if nxt is not None:
                key, message, since = nxt
                book.mark_written(key, message, since, float(t), seq)
                apply(device, message)
                book.mark_acked(seq)
                seq += 1
        elif step == "power_cycle":  # the device forgets; the host reconnects
            device.clear()
            book.requeue_all()
        elif step == "lose_unacked":  # the next write is lost on the wire, then noticed
            nxt = book.pop_next()
            if nxt is not None:
                key, message, since = nxt
                book.mark_written(key, message, since, float(t), seq)
                seq += 1
                book.requeue_unacked()
        else:
            book.set(step, float(t))
            apply(wanted, step)
    while (nxt := book.pop_next()) is not None:
        key, message, since = nxt
        book.mark_written(key, message, since, 1e9, None)
        apply(device, message)
    off = {k: v for k, v in wanted.items() if v is not None and v != m.as_seen_by(Stop(k[0]), k)}
    assert {k: v for k, v in device.items() if v != m.as_seen_by(Stop(k[0]), k)} == off
