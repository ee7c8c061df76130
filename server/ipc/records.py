"""Every record that crosses a socket between the server's processes, declared once.

A record is a frozen, slotted dataclass; on the socket it is one msgpack array `[tag, *fields]`
in the declared field order (`to_array`, `from_array`). Trailing fields a record declares as a
`TAIL` are left out together when they are all None (a tracker sample without points, an input
without a value, a cue record of one tool), so the bytes are those of the positional lists the
processes exchanged before the records were typed (tests/vectors/ipc_records.json pins them).

Each channel (`Channel`) lists the records one direction of one socket carries and decodes an
array to its record by tag; an unknown tag or a wrong shape is `BadRecord` (a ValueError naming
the channel and the tag), which a receiver reports and survives. Receivers dispatch on the
record's class, never on a tag string. docs/architecture.md "The mailbox" has the tables of
these declarations (server/ipc/doc.py writes them; a test fails when they are stale).

Pure: no msgpack and no socket here (server/ipc/__init__.py packs and sends).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any, ClassVar

from server.core.frozen import quick_init


class BadRecord(ValueError):
    """An array that is not a record of the channel it came on (unknown tag, wrong shape)."""


def doc(text: str, **kw) -> Any:
    """A record field with its meaning (the docs' tables show it)."""
    return field(metadata={"doc": text}, **kw)


def frozen(cls):
    """A frozen, slotted dataclass with the quick constructor of server/core/frozen.py (a frozen
    dataclass's own __init__ made a tracker sample's record 0.9 µs instead of 0.5 on the loop's
    1 kHz path), and FIELDS, its field names in order."""
    cls = quick_init(dataclass(frozen=True, slots=True)(cls))
    cls.FIELDS = tuple(f.name for f in fields(cls))
    return cls


def record(tag: str, *, tail: int = 0):
    """Declare a record class: frozen and slotted, with its tag and the number of trailing fields
    that may be left out together (each must default to None)."""
    def wrap(cls):
        cls.TAG, cls.TAIL = tag, tail
        return frozen(cls)
    return wrap


class Record:
    """The base of every record: `[TAG, *fields]` on the socket."""

    __slots__ = ()
    TAG: ClassVar[str]
    TAIL: ClassVar[int] = 0
    FIELDS: ClassVar[tuple[str, ...]] = ()
    SHAPE: ClassVar[str | None] = None  # the array as the docs show it, for a record with its own to_array

    def to_array(self) -> list:
        values = [getattr(self, name) for name in self.FIELDS]
        tail = self.TAIL
        if tail and all(v is None for v in values[-tail:]):
            del values[-tail:]
        return [self.TAG, *values]

    @classmethod
    def from_array(cls, array: list) -> Record:
        n = len(array) - 1
        if n != len(cls.FIELDS) and n != len(cls.FIELDS) - cls.TAIL:  # the tail goes out whole or not at all
            raise BadRecord(f"the {cls.TAG!r} record has {len(cls.FIELDS)} fields "
                            f"({', '.join(cls.FIELDS) or 'none'}), not {n}")
        return cls(*array[1:])


@dataclass(frozen=True, slots=True)
class Malformed:
    """Not a record: what a drain hands on in place of an array no record of its channel
    matches, so the receiver can report it (never sent)."""
    error: str


# ---- hub → loop: the mailbox (server/hub/supervisor.py → server/loop/process.py) ------------------
@record("tracker", tail=3)
class TrackerSample(Record):
    """A tracker sample for the loop (server/wire/messages.py Tracker.loop_record; the tracker UDP
    port builds the same, server/loop/tracker_udp.py)."""
    source: int | str = doc("the /ws client id, or `udp:HOST:PORT` of the datagram's sender")
    seq: int = doc("the sample's sequence number")
    t_ms: float = doc("the sender's time of the sample, ms")
    pos: list = doc("`[x, y, z]`, metres")
    quat: list | None = doc("`[w, x, y, z]` or null")
    recv_ns: int = doc("when the hub (or the loop's UDP port) received it, CLOCK_MONOTONIC ns")
    point: str | None = doc("the point `pos` is (null: the primary tool's); the three last fields are left "
                            "out together when all are null", default=None)
    points: dict | None = doc("more points of the sample, `{name: [x, y, z]}`, or null", default=None)
    ttl_ms: float | None = doc("the sample is good for this long (null: held)", default=None)

    @classmethod
    def from_array(cls, array: list) -> TrackerSample:  # the 1 kHz path: one length test, no slicing
        n = len(array)
        if n == 7:
            return cls(array[1], array[2], array[3], array[4], array[5], array[6])
        if n == 10:
            return cls(array[1], array[2], array[3], array[4], array[5], array[6], array[7], array[8], array[9])
        return Record.from_array.__func__(cls, array)  # says what is wrong (no super(): slots made a new class)


@record("input", tail=1)
class Input(Record):
    """A key or experimenter command, checked by the hub (server/hub/control.py)."""
    client_id: int = doc("the sender (0: REST or the hub itself)")
    key: str = doc("the key or command")
    action: str = doc("`down`, `up` or `press`")
    value: Any = doc("the command's argument; left out when null", default=None)


@record("trial")
class Trial(Record):
    """Start a trial of the running scenario, or end it."""
    body: dict | None = doc('`{"phase", "params", "index"}`, or null: no trial')


@record("scenario")
class SwitchScenario(Record):
    """Switch the scenario between trials (built off the tick: server/loop/tick.py)."""
    name: str = doc("the scenario id")
    params: dict = doc("its checked parameters")
    seed: int = doc("the random seed")
    switch: int = doc("the switch's number (ScenarioControl counts them from 1; 0: unnumbered); the loop "
                      "echoes it in its `scenario` announcement, so a switch in flight is matched by number, "
                      "not by id", default=0)


@record("devices")
class DeviceReport(Record):
    """The device host's report, for the scenario (the refusals no device shows); the hub also
    hands it to its listeners (the recorder)."""
    report: dict = doc('`{"refusals": [text, ...], "status": {device: status}}`, with audio devices also '
                       '`"underruns": {device: count}`')


@record("record")
class RecordEvery(Record):
    """Trajectory rows ride with the state records every Nth tick while an experiment records."""
    every_n_ticks: int = doc("N; 0: off")


@record("tracker_gone")
class TrackerGone(Record):
    """A /ws client that sent tracker samples left: the tools it drove go home."""
    client_id: int = doc("the client")


@record("stop")
class Stop(Record):
    """Stop (the loop, the device host, the tracker host)."""


# ---- loop → hub ------------------------------------------------------------------------------
@record("hello")
class Hello(Record):
    """A child process started (the loop, the device host, the tracker host)."""
    info: dict = doc('the loop: `{"pid", "rt", "tick_hz", "state_hz", "scenario", "cpu"}`; '
                     'the hosts: `{"pid"}` (the tracker host also `"rt"`)')


@record("scene")
class SceneAnnounce(Record):
    """The scene the loop simulates from now on (before its scenario)."""
    scene: dict = doc("the scene (docs/protocol.md scene format)")
    hash: str = doc("its hash")


@record("scenario")
class ScenarioAnnounce(Record):
    """What the loop runs now (after a switch, a trial change, or a failed switch)."""
    info: dict = doc('`{"id", "params", "seed", "trial", "tick"}` (+ `"failed"`: the switch that could not '
                     'be built)')


@record("fail_safe")
class FailSafe(Record):
    """A failed tick turned every actuator off."""


@record("log")
class Log(Record):
    """A log line for the hub's log."""
    level: str = doc("`warning` or `error`")
    text: str = doc("the line")


@record("fault")
class Fault(Record):
    """A tick failed: at a streak's first failure, then at most every 100 ticks while it lasts."""
    failures: int = doc("ticks failed since the loop started")
    tick: int = doc("the failed tick")
    error: str = doc("the exception, at most 300 characters")
    SHAPE = '["fault", {"failures", "tick", "error"}]'

    def to_array(self) -> list:
        return ["fault", {"failures": self.failures, "tick": self.tick, "error": self.error}]

    @classmethod
    def from_array(cls, array: list) -> Fault:
        body = _body(cls, array)
        return cls(body.get("failures", 0), body.get("tick"), body.get("error", ""))


@record("recovered")
class Recovered(Record):
    """The first good tick after failing ones."""
    tick: int = doc("the tick")
    failures: int = doc("ticks failed since the loop started")
    SHAPE = '["recovered", {"tick", "failures"}]'

    def to_array(self) -> list:
        return ["recovered", {"tick": self.tick, "failures": self.failures}]

    @classmethod
    def from_array(cls, array: list) -> Recovered:
        body = _body(cls, array)
        return cls(body.get("tick"), body.get("failures"))


def _body(cls, array: list) -> dict:
    if len(array) != 2 or not isinstance(array[1], dict):
        raise BadRecord(f"a {cls.TAG!r} record is [{cls.TAG!r}, {{{', '.join(cls.FIELDS)}}}]")
    return array[1]


@frozen
class Recorded:
    """What only the recorder (and the loop's own bookkeeping) reads of a state record."""
    trajectory: list  # rows since the last state record (server/core/records.py TRAJECTORY_COLUMNS)
    trackers: list    # applied tracker samples: [client_id, seq, t_ms, recv_ns, applied_ns]
    finished: list    # trial ends: {"tick", "metrics", ...} (ScenarioOutput.finished)
    point_rows: list  # several tracked points: [tick, {point: [x, y, z]}] (records.py POINT_ROW)


@frozen
class Timing:
    """The loop's timing since the last state record, for the hub's telemetry and health."""
    samples: bytes        # TIMING_SAMPLE rows of int64 (server/core/records.py)
    failures: int = 0     # ticks failed since the loop started
    resyncs: int | None = None  # the deadline scheduler's resyncs (the loop process's; None: no scheduler)


_RECORDED_KEYS = ("trackers", "trajectory", "finished", "point_rows")
_TIMING_KEYS = ("samples", "failures", "resyncs")
_NOT_SEEN = frozenset(_RECORDED_KEYS + _TIMING_KEYS)


@record("state")
class State(Record):
    """A state record: what clients see, what the recorder needs, the loop's timing. On the socket
    one map: the view's keys, then `samples`, `trackers`, `trajectory`, `finished`, and
    `point_rows`, `failures` and `resyncs` when they have anything (an empty list, 0 and null are
    left out)."""
    view: dict = doc("what clients see: the wire `state` fields in their order (docs/protocol.md), without "
                     "`type` and `telemetry` (the hub adds them); a run nobody draws has only `frame, tick, t, "
                     "scene, cues, hud, events`")
    recorded: Recorded = doc("`trajectory` (every Nth tick while recording), `trackers` (applied samples: "
                             "`[client_id, seq, t_ms, recv_ns, applied_ns]`), `finished` (trial ends), "
                             "`point_rows` (several tracked points)")
    timing: Timing = doc("`samples` (int64 rows: period_ns, cost_ns, published), `failures`, `resyncs`")
    SHAPE = ('["state", {view…, "samples", "trackers", "trajectory", "finished", ("point_rows"), ("failures"), '
             '("resyncs")}]')

    @property
    def tick(self) -> int:
        return self.view["tick"]

    @property
    def frame(self) -> int:
        return self.view["frame"]

    def to_array(self) -> list:
        recorded, timing = self.recorded, self.timing
        body = dict(self.view)
        body["samples"] = timing.samples
        body["trackers"] = recorded.trackers
        body["trajectory"] = recorded.trajectory
        body["finished"] = recorded.finished
        if recorded.point_rows:
            body["point_rows"] = recorded.point_rows
        if timing.failures:
            body["failures"] = timing.failures
        if timing.resyncs is not None:
            body["resyncs"] = timing.resyncs
        return ["state", body]

    @classmethod
    def from_array(cls, array: list) -> State:
        if len(array) != 2 or not isinstance(array[1], dict):
            raise BadRecord("a 'state' record is ['state', {...}]")
        body = array[1]  # an absent list is empty, absent samples are none (the loop always sends them)
        recorded = Recorded(body.get("trajectory", []), body.get("trackers", []), body.get("finished", []),
                            body.get("point_rows", []))
        timing = Timing(body.get("samples", b""), body.get("failures", 0), body.get("resyncs"))
        return cls({k: v for k, v in body.items() if k not in _NOT_SEEN}, recorded, timing)


# ---- loop → device host: the cue channel (server/loop/process.py → devices/feed.py) ---------------
@record("cues", tail=1)
class Cues(Record):
    """A tick's cues, in every tick whose cues changed, before that tick's state record."""
    tick: int = doc("the tick")
    sent_ns: int = doc("when the loop sent it, CLOCK_MONOTONIC ns")
    cues: list = doc("the primary tool's cues, wire form (`[]`: every actuator off)")
    fingers: dict | None = doc("several tools: `{point name: [cue, ...]}` of every other tool; left out "
                               "with one tool", default=None)

    @classmethod
    def from_array(cls, array: list) -> Cues:
        if not (len(array) in (4, 5) and isinstance(array[2], int) and isinstance(array[3], list)
                and (len(array) == 4 or _is_finger_cues(array[4]))):
            raise BadRecord(f"not a cue record: {array!r:.120}")
        return cls(*array[1:])


def _is_finger_cues(value) -> bool:
    return isinstance(value, dict) and all(isinstance(k, str) and isinstance(v, list) for k, v in value.items())


@record("alive")
class Alive(Record):
    """The loop's heartbeat when it sent nothing on the cue channel for CUE_HEARTBEAT_MS."""
    tick: int = doc("the tick")
    sent_ns: int = doc("when the loop sent it, CLOCK_MONOTONIC ns")

    @classmethod
    def from_array(cls, array: list) -> Alive:
        if not (len(array) == 3 and isinstance(array[1], int) and isinstance(array[2], int)):
            raise BadRecord(f"not an alive record: {array!r:.120}")
        return cls(array[1], array[2])


# ---- the hub ⇄ the device host process (server/hub/device_host.py, devices/device_host_process.py) ----
@record("snapshot")
class SnapshotRequest(Record):
    """The hub asks for the devices as the console shows them."""
    request: int = doc("the request id the answer names")
    writes: int = doc("how many recent writes per device to include")


@record("report")
class DeviceStatus(Record):
    """A device's status, identity or refusals changed."""
    report: dict = doc('`{"refusals": [...], "status": {device: status}}`, with audio devices also '
                       '`"underruns": {device: count}`')


# ---- the device host ⇄ an audio worker process (devices/audio/device.py, devices/audio/worker.py) ----
@record("stimuli")
class AudioStimuli(Record):
    """The newest stimulus of every output channel of an audio device (the latest wins)."""
    generation: int = doc("counts the hand-overs; the worker reports the sample at which each started")
    stimuli: list = doc("one map per output channel: the fields of devices/audio/synth.py `Stimulus`")


@record("audio_status")
class AudioStatus(Record):
    """The audio worker's stream: `connected`, `disconnected` (the audio server stopped) or `refused`."""
    status: str = doc("connected | disconnected | refused")
    reason: str = doc("why, for people (a refusal names what is wrong)")


@record("counters")
class AudioCounters(Record):
    """The stream's counters, every 50 ms and after each hand-over."""
    blocks: int = doc("blocks rendered by this worker")
    underruns: int = doc("blocks its audio server called for too late (PortAudio's output underflow)")
    next_sample: int = doc("the first sample of the next block (the synth's clock)")
    took: list = doc("`[[generation, first sample], ...]` of the hand-overs since the last counters")


@record("profiles")
class DeviceProfiles(Record):
    """The devices' profiles as they identified themselves."""
    profiles: dict = doc("`{device: profile table}`")


@record("snapshot")
class Snapshot(Record):
    """The answer to a SnapshotRequest."""
    request: int = doc("the request id")
    snapshot: dict = doc("DeviceManager.snapshot plus the feed's `info()` as `feed`")


# ---- the hub ⇄ the tracker host process (server/hub/tracker_host.py, server/tracking/tracker_host_process.py)
@record("calibrate")
class Calibrate(Record):
    """Set (or reset) a source's calibration."""
    request: int = doc("the request id the answer names")
    source: str = doc("the source")
    table: dict | None = doc("the calibration table, or null: back to the default")


@record("capture")
class Capture(Record):
    """The mean raw position of each point over the last seconds."""
    request: int = doc("the request id the answer names")
    source: str = doc("the source")
    seconds: float = doc("how far back")


@record("health")
class SourcesHealth(Record):
    """Every source's health, every 0.1 s."""
    sources: list = doc("`[source health, ...]`")


@record("answer")
class Answer(Record):
    """The answer to a Calibrate or Capture."""
    request: int = doc("the request id")
    result: dict = doc('`{"ok": bool, ...}`')


class Channel:
    """One direction of one socket: the records it carries, decoded by tag."""

    def __init__(self, name: str, records: tuple[type[Record], ...], doc_text: str):
        self.name = name
        self.records = records
        self.doc = doc_text
        self.by_tag = {cls.TAG: cls for cls in records}
        assert len(self.by_tag) == len(records), f"{name}: two records with one tag"

    def decode(self, array: Any) -> Record:
        """The record `array` is; BadRecord when it is none of this channel's."""
        if not isinstance(array, list) or not array:
            raise BadRecord(f"{self.name}: not a record: {array!r:.80}")
        cls = self.by_tag.get(array[0]) if isinstance(array[0], str) else None
        if cls is None:
            raise BadRecord(f"{self.name}: unknown record {array[0]!r:.40}; expected one of {', '.join(self.by_tag)}")
        try:
            return cls.from_array(array)
        except BadRecord as exc:
            raise BadRecord(f"{self.name}: {exc}") from None
        except TypeError as exc:
            raise BadRecord(f"{self.name}: a bad {cls.TAG!r} record ({exc})") from None


TO_LOOP = Channel("hub → loop", (TrackerSample, Input, Trial, SwitchScenario, DeviceReport, RecordEvery,
                                 TrackerGone, Stop),
                  "the mailbox (server/hub/supervisor.py sends, server/loop/process.py drains each tick)")
FROM_LOOP = Channel("loop → hub", (Hello, SceneAnnounce, ScenarioAnnounce, State, FailSafe, Log, Fault, Recovered),
                    "the mailbox's other direction (server/loop/process.py sends, the hub's records reader)")
CUES = Channel("loop → device host", (Cues, Alive),
               "the cue channel (server/loop/process.py sends, devices/feed.py reads on its own thread)")
TO_DEVICE_HOST = Channel("hub → device host", (SnapshotRequest, Stop),
                         "the device host's control socket (server/hub/device_host.py sends)")
FROM_DEVICE_HOST = Channel("device host → hub", (Hello, DeviceStatus, DeviceProfiles, Snapshot),
                           "its other direction (devices/device_host_process.py sends)")
TO_TRACKER_HOST = Channel("hub → tracker host", (Calibrate, Capture, Stop),
                          "the tracker host's control socket (server/hub/tracker_host.py sends)")
FROM_TRACKER_HOST = Channel("tracker host → hub", (Hello, SourcesHealth, Answer),
                            "its other direction (server/tracking/tracker_host_process.py sends)")
TO_AUDIO_WORKER = Channel("device host → audio worker", (AudioStimuli, Stop),
                          "an audio device's worker socket (devices/audio/device.py sends)")
FROM_AUDIO_WORKER = Channel("audio worker → device host", (AudioStatus, AudioCounters),
                            "its other direction (devices/audio/worker.py sends)")
CHANNELS = (TO_LOOP, FROM_LOOP, CUES, TO_DEVICE_HOST, FROM_DEVICE_HOST, TO_TRACKER_HOST, FROM_TRACKER_HOST,
            TO_AUDIO_WORKER, FROM_AUDIO_WORKER)
