"""A state record the loop process could not hand to the hub (its end of the mailbox full) loses
nothing the recorder needs: its trajectory rows, events, trial ends and applied tracker samples ride
with the next state record; other records wait in order (server/loop/process.py)."""

from collections import deque

from scenarios.contact_angle import ContactAngle
from server import ipc
from server.loop.tick import Loop
from server.loop.process import _send_in_order
from server.loop.simulation import Simulation
from server.ipc.records import FROM_LOOP, Input, Log, RecordEvery, TrackerSample
from tests.ipc import sent, state_map

MS = 1_000_000


def test_an_unsent_state_records_rows_events_and_trackers_go_out_with_the_next_one():
    core = Loop(Simulation(ContactAngle()), state_hz=100)
    core.apply(RecordEvery(1), 0)
    core.record_sample(MS, 20_000)  # a timing sample the first state record carries
    states = []
    for t in range(40):
        records = [Input(1, "space", "press")] if t == 3 else []
        if t == 5:
            records.append(TrackerSample(7, 1, 0.0, [0.0, 0.0, 0.5], None, 0))
        out = core.tick(records, t * MS)
        core.record_sample(MS, 10_000)
        if out.state is not None:
            states.append(state_map(out.state))
            if len(states) == 1:
                core.unsent(out.state)  # the hub's end was full
    rows = [row[0] for state in states[1:] for row in state["trajectory"]]
    assert rows == list(range(rows[0], rows[-1] + 1)) and rows[0] == states[0]["trajectory"][0][0] == 0, \
        "every tick's row once, in order, the unsent ones first"
    events = [e for state in states[1:] for e in state["events"] if e["name"] == "input"]
    assert [e["tick"] for e in events] == [3]
    assert [t[1] for state in states[1:] for t in state["trackers"]] == [1]
    assert len(states[0]["samples"]) == 24
    assert sum(len(state["samples"]) for state in states[1:]) == 24 * (1 + states[-1]["tick"]), \
        "the unsent record's timing samples too"
    assert core.states_unsent == 1


def test_records_wait_in_order_while_the_hub_does_not_read():
    ours, theirs = ipc.channel_pair()
    try:
        backlog = deque([Log("info", str(i)) for i in range(3)])
        big = Log("info", "x" * 60_000)
        while ipc.send_record(ours, big):  # fill the hub's end
            pass
        _send_in_order(ours, backlog)
        assert len(backlog) == 3, "nothing is sent past a full mailbox, nothing is dropped"
        theirs.setblocking(False)
        while True:
            try:
                theirs.recv(ipc.MAX_RECORD_BYTES)
            except BlockingIOError:
                break
        _send_in_order(ours, backlog)
        assert not backlog
        got = [sent(r) for r in ipc.drain(theirs, FROM_LOOP)]
        assert [r[2] for r in got] == ["0", "1", "2"]
    finally:
        ours.close()
        theirs.close()
