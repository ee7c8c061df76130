"""The I/O-free client session (server/hub/session.py): hello and its grace period, version,
roles, one error per bad frame, what the client is sent and in which order. No server, no socket:
frames go in as bytes/text with a time, frames come out of `next_frame()`."""

from __future__ import annotations

import json
import random
from pathlib import Path

import msgpack
import pytest

from server.hub.event_log import EventLog
from server.hub.outbox import MAX_PENDING_ERRORS, Close
from server.hub.session import Command, ServerInfo, Session, ToLoop
from server.wire import codec
from tests.hub.access_fakes import ADMIN, ADMIN_SECRET, gate
from server.ipc.records import TrackerGone, TrackerSample

INVALID = json.loads((Path(__file__).parents[1] / "vectors" / "invalid.json").read_text())["frames"]
SERVER = ServerInfo("viestac/test", 1000, 60.0)
T0 = 5_000_000_000  # the connection opened at this monotonic time (ns)
SCENE_A = {fmt: codec.encode({"type": "scene", "v": 1, "hash": "aaaa", "scene": {"name": "a"}}, fmt)
           for fmt in codec.FORMATS}
SCENE_B = {fmt: codec.encode({"type": "scene", "v": 1, "hash": "bbbb", "scene": {"name": "b"}}, fmt)
           for fmt in codec.FORMATS}


def frame(message: dict, fmt: str = "msgpack") -> bytes | str:
    return msgpack.packb(message) if fmt == "msgpack" else json.dumps(message)


def hello(role: str = "participant", v: int = 1, fmt: str = "msgpack") -> bytes | str:
    """A hello with the admin's token; the admin holds the lease (tests/hub/access_fakes.py).
    What other tokens may do: tests/hub/test_session_access.py."""
    return frame({"type": "hello", "v": v, "role": role, "client": "pytest", "token": ADMIN_SECRET}, fmt)


def tracker(seq: int = 0) -> bytes:
    return frame({"type": "tracker", "seq": seq, "t": 12.5, "pos": [0.1, 0.2, 0.3]})


def state(scene: str, fmt: str = "msgpack", tick: int = 0) -> bytes | str:
    return codec.encode({"type": "state", "tick": tick, "scene": scene}, fmt)


def sent(session: Session) -> list:
    """Everything the sender would send now, decoded (a Close stays a Close)."""
    out = []
    while (item := session.outbox.next_frame()) is not None:
        out.append(item if isinstance(item, Close) else codec.decode(item, session.fmt))
    return out


def kinds(messages: list) -> list:
    return [m if isinstance(m, Close) else m["type"] for m in messages]


def new(fmt: str = "msgpack", **kw) -> Session:
    s = Session(7, fmt, SERVER, T0, gate=gate()[0], **kw)
    s.set_scene("aaaa", SCENE_A)
    return s


# ---- hello --------------------------------------------------------------------------------------
@pytest.mark.parametrize("fmt", ["msgpack", "json"])
def test_hello_is_welcomed_with_its_role_then_the_scene(fmt):
    s = new(fmt)
    assert sent(s) == [] and not s.outbox.pending  # nothing before the hello
    assert s.receive(hello("operator", fmt=fmt), T0 + 1000) == []
    welcome, scene = sent(s)
    assert welcome == {"type": "welcome", "v": 1, "client_id": 7, "role": "operator", "server": "viestac/test",
                       "tick_hz": 1000, "state_hz": 60, "format": fmt, "minor": 6,  # v1.6 (was 5)
                       "identity": {"token_id": ADMIN.token_id, "role": "admin", "site": None, "session": None}}
    assert scene["hash"] == "aaaa" and s.role == "operator" and s.client_name == "pytest"


def test_a_second_hello_is_refused():
    s = new()
    s.receive(hello(), T0)
    sent(s)
    s.receive(hello("operator"), T0 + 1)
    assert [m["code"] for m in sent(s)] == ["bad_message"] and s.role == "participant"


@pytest.mark.parametrize("late", [False, True])
def test_another_protocol_version_gets_an_error_then_close_1002_and_nothing_more(late):
    s = new()
    if late:
        s.receive(hello(), T0)
    sent(s)
    s.receive(hello(v=2), T0 + 1)
    assert s.closing
    messages = sent(s)
    assert kinds(messages) == ["error", Close(1002)] and messages[0]["code"] == "unsupported_version"
    # after the close decision nothing is read, queued or sent
    assert s.receive(tracker(), T0 + 2) == []
    s.set_scene("bbbb", SCENE_B)
    s.offer_state(state("bbbb"), "bbbb")
    assert sent(s) == [] and not s.outbox.pending and s.hello_wait_s(T0 + 3) is None


# ---- bad frames and roles -----------------------------------------------------------------------
def test_every_bad_frame_gets_exactly_one_error_and_the_session_goes_on():
    s = new()
    s.receive(hello(), T0)
    sent(s)
    for vector in INVALID:
        assert s.receive(bytes.fromhex(vector["msgpack_hex"]), T0 + 1) == []
        replies = sent(s)
        assert [m["code"] for m in replies] == [vector["code"]], vector["name"]
        assert replies[0]["message"]
    for data, code in ((None, "bad_encoding"), ("{}", "bad_encoding"),
                       (b"\x81\xa4type\xa5input" + b"\x00" * (64 * 1024), "too_large")):
        s.receive(data, T0 + 2)
        assert [m["code"] for m in sent(s)] == [code]
    assert s.errors == len(INVALID) + 3 and not s.closing
    assert s.receive(tracker(3), T0 + 3)[0].record.seq == 3  # still serving


def test_a_participant_tracker_becomes_a_loop_record_with_the_receive_time():
    s = new()
    s.receive(hello(), T0)
    events = s.receive(frame({"type": "tracker", "seq": 4, "t": 9.0, "pos": [1, 2, 3], "quat": [1, 0, 0, 0]}), T0 + 77)
    assert events == [ToLoop(TrackerSample(7, 4, 9.0, [1.0, 2.0, 3.0], [1.0, 0.0, 0.0, 0.0], T0 + 77),
                             busy="the loop's input mailbox is full; tracker sample dropped")]
    assert s.tracker_count == 1 and s.last_tracker == {"seq": 4, "t": 9.0, "pos": [1.0, 2.0, 3.0]}
    s.reply_error("busy", events[0].busy)  # what the hub does when the mailbox is full
    assert [m["code"] for m in sent(s)[2:]] == ["busy"]


def test_input_becomes_a_command_with_role_and_client():
    s = new()
    s.receive(hello("operator"), T0)
    events = s.receive(frame({"type": "input", "key": "tap_angle", "action": "press", "value": -30}), T0 + 1)
    assert events == [Command("tap_angle", "press", -30.0, "operator", 7)]


@pytest.mark.parametrize("message", [{"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 1]},
                                     {"type": "input", "key": "r", "action": "press"}])
def test_an_observer_may_send_nothing_but_hello(message):
    s = new()
    s.receive(hello("observer"), T0)
    sent(s)
    assert s.receive(frame(message), T0 + 1) == []
    (error,) = sent(s)
    assert error["code"] == "forbidden" and message["type"] in error["message"]


def test_a_client_that_floods_errors_without_reading_gets_a_bounded_queue():
    s = new()
    s.receive(hello(), T0)
    for _ in range(MAX_PENDING_ERRORS + 50):
        s.receive(b"\xc1", T0 + 1)
    assert s.errors == MAX_PENDING_ERRORS + 50
    assert kinds(sent(s)) == ["welcome", "scene"] + ["error"] * MAX_PENDING_ERRORS
    s.receive(b"\xc1", T0 + 2)  # read: replies are queued again
    assert kinds(sent(s)) == ["error"]


def test_disconnect_tells_the_loop_only_about_clients_that_sent_trackers():
    watcher, driver = new(), new()
    watcher.receive(hello(), T0)
    driver.receive(hello(), T0)
    driver.receive(tracker(), T0 + 1)
    assert watcher.disconnected() == []
    assert driver.disconnected() == [ToLoop(TrackerGone(7))]


# ---- what is sent, in which order ---------------------------------------------------------------
def test_state_frames_are_latest_wins_and_only_for_welcomed_clients():
    s = new()
    s.offer_state(state("aaaa", tick=1), "aaaa")  # not welcomed yet: not offered
    s.receive(hello(), T0)
    s.offer_state(state("aaaa", tick=2), "aaaa")
    s.offer_state(state("aaaa", tick=3), "aaaa")
    messages = sent(s)
    assert kinds(messages) == ["welcome", "scene", "state"] and messages[2]["tick"] == 3
    assert (s.outbox.frames_sent, s.outbox.frames_dropped) == (1, 1)


def test_the_events_of_a_frame_a_client_missed_come_first_in_its_next_frame():
    """The picture of a replaced (or never offered) frame may go; its events may not: the next
    frame sent carries them in front of its own, each once, in order (server/hub/event_log.py)."""
    log = EventLog()
    fast, slow = new(events=log), new(events=log)
    for s in (fast, slow):
        s.receive(hello(), T0)
        sent(s)

    def offer(tick: int, events: list, to) -> None:
        message = {"type": "state", "tick": tick, "scene": "aaaa", "events": events}
        upto = log.add(events)
        for s in to:
            s.offer_state(codec.encode(message, s.fmt), "aaaa", message, upto)

    tap, release = {"tick": 2, "name": "tap"}, {"tick": 3, "name": "release"}
    offer(1, [], (fast, slow))
    assert [m["events"] for m in sent(fast)] == [[]] and [m["events"] for m in sent(slow)] == [[]]
    offer(2, [tap], (fast, slow))
    assert [m["events"] for m in sent(fast)] == [[tap]]
    go = {"tick": 5, "name": "go"}
    got_fast = []
    offer(3, [release], (fast, slow))  # replaces the tap's frame in the slow client's slot
    got_fast += sent(fast)
    offer(4, [], (fast,))  # the hub offered only the newest frame: the slow client never saw 4 ...
    got_fast += sent(fast)
    offer(5, [go], (fast, slow))  # ... and 3 is replaced by 5 before it was sent
    got_fast += sent(fast)
    assert [(m["tick"], m["events"]) for m in got_fast] == [(3, [release]), (4, []), (5, [go])]
    assert [(m["tick"], m["events"]) for m in sent(slow)] == [(5, [tap, release, go])]
    assert (slow.outbox.events_carried, fast.outbox.events_carried) == (2, 0)
    offer(6, [], (slow,))
    assert [m["events"] for m in sent(slow)] == [[]], "each event once"


def test_a_state_of_the_previous_scene_is_never_sent_after_the_new_scene():
    """The slot holds a frame of scene A when scene B is queued; control goes first, so without
    the rule the client would get scene B, then a state naming A."""
    s = new()
    s.receive(hello(), T0)
    sent(s)
    s.offer_state(state("aaaa", tick=1), "aaaa")
    s.set_scene("bbbb", SCENE_B)
    messages = sent(s)
    assert kinds(messages) == ["scene"] and messages[0]["hash"] == "bbbb"
    assert s.outbox.frames_dropped == 1
    s.offer_state(state("aaaa", tick=2), "aaaa")  # still in flight from before the switch
    assert sent(s) == []
    s.offer_state(state("bbbb", tick=3), "bbbb")
    assert [(m["scene"], m["tick"]) for m in sent(s)] == [("bbbb", 3)]


def test_a_state_before_any_scene_is_not_sent():
    s = Session(1, "json", SERVER, T0, gate=gate()[0])
    s.receive(hello(fmt="json"), T0)
    s.offer_state(state("aaaa", "json"), "aaaa")
    assert kinds(sent(s)) == ["welcome"]
    s.set_scene("aaaa", SCENE_A)
    s.offer_state(state("aaaa", "json"), "aaaa")
    assert kinds(sent(s)) == ["scene", "state"]


def test_a_scene_not_yet_sent_is_superseded_by_the_next():
    s = new()
    s.receive(hello(), T0)
    s.receive(b"\xc1", T0 + 1)
    s.set_scene("bbbb", SCENE_B)
    s.offer_state(state("bbbb"), "bbbb")
    messages = sent(s)
    # the welcome's scene A never went out: the client gets B once, in order after the error
    assert kinds(messages) == ["welcome", "error", "scene", "state"]
    assert messages[2]["hash"] == "bbbb" and messages[3]["scene"] == "bbbb"


def test_ordering_holds_for_any_interleaving_of_scenes_and_states():
    """Random interleavings of scene switches, state offers and sends: every state sent names the
    last scene sent, and the newest scene is always delivered."""
    rng = random.Random(17)
    scenes = {h: {fmt: codec.encode({"type": "scene", "v": 1, "hash": h, "scene": {}}, fmt) for fmt in codec.FORMATS}
              for h in ("s0", "s1", "s2")}
    states = 0
    for _ in range(200):
        s = Session(1, "msgpack", SERVER, T0, gate=gate()[0])
        s.receive(hello(), T0)
        current, last_scene = None, None
        for _ in range(40):
            action = rng.random()
            if action < 0.2:
                current = rng.choice([h for h in scenes if h != current])
                s.set_scene(current, scenes[current])
            elif action < 0.6 and current is not None:
                named = current if rng.random() < 0.8 else rng.choice(list(scenes))  # some in flight from before
                s.offer_state(state(named), named)
            else:
                for _ in range(rng.randint(1, 3)):
                    item = s.outbox.next_frame()
                    if item is None:
                        break
                    message = codec.decode(item)
                    if message["type"] == "scene":
                        last_scene = message["hash"]
                    elif message["type"] == "state":
                        assert message["scene"] == last_scene
                        states += 1
        for message in sent(s):
            if message["type"] == "scene":
                last_scene = message["hash"]
            elif message["type"] == "state":
                assert message["scene"] == last_scene
                states += 1
        assert last_scene == current
    assert states > 500  # the walks did send states
