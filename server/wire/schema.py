"""Protocol v1.6: every message declared once, as data (docs/protocol.md).

Everything else follows from this module: the Python parsers and builders (messages.py, through
the checker in check.py), the message tables of docs/protocol.md and the browser client's schema
(clients/web/src/schema.js), both written by `python -m server.wire.doc`, and the coverage of the
shared vectors (tests/wire/test_schema.py). A field's type is a plain JSON-able map, so the same
data drives the JavaScript checker (clients/web/src/protocol.js):

- `{"kind": "int", "min", "max"}`: an integral number within +-(2**53 - 1); an integral float
  (3.0) counts as the integer 3, a non-integral one is refused;
- `{"kind": "number", "min", "max", "min_exclusive", "max_abs", "decimals"}`: any finite number;
  `decimals` says to how many decimal places the server rounds it (documentation only);
- `{"kind": "bool"}`, `{"kind": "null"}`;
- `{"kind": "string", "min_len", "max_len"}`: lengths in Unicode code points;
- `{"kind": "enum", "values"}`, `{"kind": "const", "value"}`;
- `{"kind": "vec", "size", "min", "max_abs", "decimals"}`: an array of `size` numbers;

`min`/`max` are a field's own range (outside: `bad_message`); `max_abs` is a protocol bound on a
finite number's magnitude (outside: `out_of_range`), as is ±(2**53 - 1) for every int.
- `{"kind": "quat", "norm", "decimals"}`: `[w, x, y, z]` whose norm lies in `norm`; a receiver
  divides it by its norm;
- `{"kind": "array", "items"}`, `{"kind": "tuple", "items": [...]}` (fixed length, one type per
  position), `{"kind": "map", "keys", "values"}` (string keys, each of type `keys` when given;
  any values without `values`);
- `{"kind": "any_of", "types": [...]}`: the first type that fits.

Every type carries `doc`, the short text the docs tables and error messages show.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from server.core.points import POINT_NAMES, PRIMARY_POINT
from server.core.workspace import WORKSPACE_HALF_EXTENT_M

PROTOCOL_VERSION = 1  # the major version: hello.v and welcome.v
PROTOCOL_MINOR = 6    # v1.1: welcome.minor, state.stiffness/haptic/driver; v1.2: health, bounds, input budget;
                      # v1.3: hello.token, welcome.identity, lease, unauthorized;
                      # v1.4: tracker.point/points/ttl, state.tools/points/tracking (several fingers);
                      # v1.5: ask, answer (a participant answers a study's question; the study's audio);
                      # v1.6: ask.pacing (participant-paced tasks: state, progress, feedback, breaks)
                      #       actuators, state.actuator (the participant page's actuators as a device)
SCENE_FORMAT_VERSION = 1
ROLES = ("participant", "operator", "observer")
INPUT_ACTIONS = ("down", "up", "press")
FORMATS = ("msgpack", "json")
MAX_SAFE_INT = 2**53 - 1
MAX_T_MS = float(MAX_SAFE_INT)  # a sender's timestamp in ms: epoch ms are ~1.7e12
QUAT_NORM = (0.5, 2.0)  # a tracker quaternion's norm must lie here; it is then normalised
DIRECTIONS = ("client_to_server", "server_to_client")
MAX_TOKEN_CHARS = 200  # a token is 43 characters (32 random bytes, base64url); the bound only limits abuse
MAX_ERROR_MESSAGE_CHARS = 500  # an error's text: a sentence or two; a value quoted from the client is cut first
ACTUATOR_KINDS = ("xr", "gamepad")  # a WebXR controller's haptic actuator; a Gamepad API rumble (v1.6 `actuators`)
HANDS = ("left", "right", "none")   # an XR controller's handedness; a gamepad's is "none"
TTL_MS = (1.0, 10000.0)  # a tracker sample's ttl: a streaming source sends clamp(4 × period, 20, 60) ms


def _range(low: Any, high: Any, low_open: bool = False) -> str:
    if low is not None and high is not None:
        return f" in {'(' if low_open else '['}{low}, {high}]"
    if low is not None:
        return f" {'>' if low_open else '≥'} {low}"
    if high is not None:
        return f" ≤ {high}"
    return ""


def _drop_none(**kw: Any) -> dict:
    return {k: v for k, v in kw.items() if v is not None}


def integer(min: int | None = None, max: int | None = None, doc: str | None = None) -> dict:
    return _drop_none(kind="int", min=min, max=max, doc=doc or "int" + _range(min, max))


def number(min: float | None = None, max: float | None = None, *, min_exclusive: bool = False,
           max_abs: float | None = None, decimals: int | None = None, doc: str | None = None) -> dict:
    return _drop_none(kind="number", min=min, max=max, min_exclusive=min_exclusive or None, max_abs=max_abs,
                      decimals=decimals,
                      doc=doc or "number" + _range(min, max, min_exclusive))


def boolean() -> dict:
    return {"kind": "bool", "doc": "bool"}


def null() -> dict:
    return {"kind": "null", "doc": "null"}


def string(min_len: int = 0, max_len: int | None = None, doc: str | None = None) -> dict:
    if doc is None:
        doc = "string" + (f" of {min_len}..{max_len} characters" if min_len and max_len
                          else f" ≤ {max_len} characters" if max_len else "")
    return _drop_none(kind="string", min_len=min_len or None, max_len=max_len, doc=doc)


def enum(values: tuple[str, ...]) -> dict:
    return {"kind": "enum", "values": list(values), "doc": " \\| ".join(f'`"{v}"`' for v in values)}


def const(value: str) -> dict:
    return {"kind": "const", "value": value, "doc": f'`"{value}"`'}


def vec(size: int, doc: str, *, min: float | None = None, min_exclusive: bool = False,
        max_abs: float | None = None, decimals: int | None = None) -> dict:
    return _drop_none(kind="vec", size=size, min=min, min_exclusive=min_exclusive or None, max_abs=max_abs,
                      decimals=decimals, doc=doc)


def quat(doc: str = "`[w, x, y, z]`", decimals: int | None = None) -> dict:
    return _drop_none(kind="quat", norm=list(QUAT_NORM), decimals=decimals, doc=doc)


def array(items: dict, doc: str) -> dict:
    return {"kind": "array", "items": items, "doc": doc}


def fixed(items: list[dict], doc: str) -> dict:
    return {"kind": "tuple", "items": items, "doc": doc}


def mapping(values: dict | None = None, doc: str = "map", keys: dict | None = None) -> dict:
    return _drop_none(kind="map", keys=keys, values=values, doc=doc)


def any_of(*types: dict, doc: str) -> dict:
    return {"kind": "any_of", "types": list(types), "doc": doc}


@dataclass(frozen=True)
class Field:
    name: str
    type: dict
    meaning: str
    required: bool = True  # False: a receiver accepts its absence (and null: "not given")
    since: int = 0         # the minor version that added it
    default: Any = None    # a parser's value when an optional field is absent

    def to_json(self) -> dict:
        out = {"name": self.name, "type": self.type, "required": self.required, "since": self.since,
               "meaning": self.meaning}
        if self.default is not None:
            out["default"] = self.default
        return out


@dataclass(frozen=True)
class Message:
    name: str
    direction: str  # "client_to_server" | "server_to_client"
    title: str      # the heading's note, e.g. "reply to `hello`"
    fields: tuple[Field, ...]

    def __post_init__(self) -> None:
        assert self.direction in DIRECTIONS, self.direction
        assert self.fields[0].name == "type" and self.fields[0].type == const(self.name)

    def field(self, name: str) -> Field:
        return next(f for f in self.fields if f.name == name)

    def to_json(self) -> dict:
        return {"name": self.name, "direction": self.direction, "fields": [f.to_json() for f in self.fields]}


def _type(name: str) -> Field:
    return Field("type", const(name), "")


POS = "`[x, y, z]`"
V3 = vec(3, POS)

HELLO = Message("hello", "client_to_server", "first message; optional for observers that only watch", (
    _type("hello"),
    Field("v", integer(), "protocol major version (1)"),
    Field("role", enum(ROLES), "the role asked for; the token decides what is granted (\"Authentication and "
          "roles\" below). An observer may not send `tracker` or `input` (`forbidden`)."),
    Field("client", string(max_len=64), 'free-form name/version, e.g. `"viestac-web/0.1"`', required=False,
          default=""),
    Field("token", string(max_len=MAX_TOKEN_CHARS), "the client's access token (\"Authentication and roles\"); "
          "without a valid one the server answers `unauthorized` and closes the connection (1008). Never put it "
          "in the URL", required=False, since=3),
))

_WORKSPACE_POS = vec(3, f"{POS}, each \\|·\\| ≤ {WORKSPACE_HALF_EXTENT_M:g}", max_abs=WORKSPACE_HALF_EXTENT_M)
POINT_NAME = {"kind": "enum", "values": list(POINT_NAMES), "doc": "a point name (\"Tracked points\")"}

TRACKER = Message("tracker", "client_to_server", "a tracked point (the HIP unless `point` says otherwise) and "
                  "more points of a hand, any rate; the server keeps the latest per client", (
    _type("tracker"),
    Field("seq", integer(min=0), "sender's sample counter"),
    Field("t", number(max_abs=MAX_T_MS, doc="number, \\|t\\| ≤ 2^53 − 1"), "sender's timestamp in ms on its own "
          "clock (the web client sends epoch ms: "
          "`performance.timeOrigin + performance.now()`); used for latency, never for ordering"),
    Field("pos", _WORKSPACE_POS,
          "HIP position, scene frame, scene units, inside the workspace (\"Bounds\" below; outside: `out_of_range`)"),
    Field("quat", quat(), "HIP orientation; its norm must lie in [0.5, 2] and the server divides it by its norm "
          "(zero and other norms: `bad_message`)", required=False),
    Field("point", POINT_NAME, f"the tracked point `pos` is, e.g. `\"right.thumb.tip\"` (absent: the primary "
          f"tool's, `\"{PRIMARY_POINT}\"`)", required=False, since=4),
    Field("points", mapping(_WORKSPACE_POS, "map point name → `[x, y, z]`", keys=POINT_NAME),
          "more points of the same sample, scene frame, within the workspace (a hand: every joint the tracker "
          "reports); `pos` stays required", required=False, since=4),
    Field("ttl", number(*TTL_MS), "ms this sample is good for: when no newer sample of this source arrived by "
          "then, the source is lost (\"Tracker loss\"); absent: held until the next one", required=False, since=4),
))

INPUT = Message("input", "client_to_server", "keys and commands", (
    _type("input"),
    Field("key", string(1, 32), 'a key name as in DOM `KeyboardEvent.key` (`"ArrowUp"`, `"r"`, `" "`) or a '
          "command name"),
    Field("action", enum(INPUT_ACTIONS), ""),
    Field("value", any_of(number(), boolean(), string(max_len=200),
                          doc="number \\| bool \\| string ≤ 200 characters"),
          'a command\'s argument, e.g. `{"key": "tap_angle", "action": "press", "value": -30}`', required=False),
))

ANSWER = Message("answer", "client_to_server", "a participant's answer to a question of its session's running "
                 "trial that the study marks `answered_by = \"participant\"` (the `ask` message names them)", (
    _type("answer"),
    Field("seq", integer(min=0), "the trial (`ask.seq`)", since=5),
    Field("question", string(1, 64), "the question's id (`ask.questions[].id`); v1.6: `\"pacing:continue\"` ends "
          "a participant-paced task's break (`ask.pacing.state` `break`)", since=5),
    Field("value", any_of(number(), string(max_len=200), doc="number \\| string ≤ 200 characters"),
          "the answer: a Likert point, a number, or one of the choices; the server checks it against the question as "
          "it checks the console's (`PUT /api/sessions/{id}/trials/{seq}/responses/{question}`) and records it "
          "with `entered_by` `\"participant\"`; a refusal is an `error` (`forbidden`, `bad_message`, `conflict`)",
          since=5),
))

ACTUATORS = Message("actuators", "client_to_server", "a participant page's own actuators (WebXR controllers, "
                    "gamepads): after `welcome` and whenever they change; the page is the rig's `browser` device", (
    _type("actuators"),
    Field("actuators", array(fixed([enum(ACTUATOR_KINDS), enum(HANDS)], "`[kind, hand]`"),
                             "array of `[kind, hand]`"),
          "each actuator the page can drive: `kind` `\"xr\"` (a WebXR input source's "
          "`gamepad.hapticActuators[0]`) or `\"gamepad\"` (a Gamepad API `vibrationActuator`); `hand` the XR "
          "controller's handedness, `\"none\"` for a gamepad; `[]`: none (the device is then disconnected)",
          since=6),
    Field("note", string(max_len=200), "why the page has none, for the console, e.g. `\"tracked hands have no "
          "actuator\"`", required=False, default="", since=6),
))

_OPT_STRING = any_of(null(), string(), doc="string \\| null")
_IDENTITY = mapping(doc="map `{token_id, role, site, session}`")

WELCOME = Message("welcome", "server_to_client", "reply to `hello`, or sent on connect to clients without one", (
    _type("welcome"),
    Field("v", integer(), "server's protocol major version (1)"),
    Field("minor", integer(min=0), "server's protocol minor version (6 for this document; absent from v1.0 "
          "servers)", required=False, since=1),
    Field("client_id", integer(min=1), "this connection's id (`driver` in `state` names a /ws client by it)"),
    Field("role", enum(ROLES), "the role the server assigned (may differ from the one asked for; clients follow "
          "this one)"),
    Field("server", string(), '`"viestac/<version>"`'),
    Field("tick_hz", integer(min=1), "haptic loop rate (1000)"),
    Field("state_hz", number(min=0, min_exclusive=True), "state publish rate (60 by default)"),
    Field("format", enum(FORMATS), "the encoding of this connection"),
    Field("identity", _IDENTITY, "who the token says this connection is: its `token_id` (not secret), its "
          "`role` (`admin`, `experimenter`, `participant`, `observer`), its `site` and, for a participant, its "
          "`session` (null when none)", required=False, since=3),
))

SCENE = Message("scene", "server_to_client", "static scene; on join and whenever it changes", (
    _type("scene"),
    Field("v", integer(min=1), "scene format version (1)"),
    Field("hash", string(), "the scene's hash, 16 lowercase hex digits (\"Scene hash\" below); every state frame "
          "names it"),
    Field("scene", mapping(doc="map"), "the scene description (\"Scene format\" below)"),
))

_CONTACT = fixed([string(min_len=1, doc="object_id"), vec(3, "`[nx, ny, nz]`", decimals=6),
                  number(min=0, decimals=9, doc="depth")], "`[object_id, [nx, ny, nz], depth]`")
_POSE = fixed([string(min_len=1, doc="object_id"), vec(3, POS, decimals=9), quat(decimals=9)],
              "`[object_id, [x, y, z], [w, x, y, z]]`")
_DRIVER = fixed([any_of(integer(min=0), string(min_len=1), doc="client_id"), integer(min=0, doc="seq")],
                "`[client_id, seq]`")

_TOOL = mapping(doc="map `{name, hip, proxy, contact, lost}`")

STATE = Message("state", "server_to_client", "per published frame; 60 Hz by default, plus a frame in any tick whose "
                "device cues changed; at most `state_hz` + 60 a second per client (\"Frame rate ceiling\")", (
    _type("state"),
    Field("frame", integer(min=0), "publish counter"),
    Field("tick", integer(min=0), "loop tick of this state (sim time = tick / tick_hz)"),
    Field("t", number(), "server monotonic time of the tick, seconds (CLOCK_MONOTONIC in ns / 1e9, not rounded)"),
    Field("scene", string(), "hash of the scene the loop simulated in this tick; every state after a `scene` "
          "message names that scene until the next `scene` message"),
    Field("hip", vec(3, POS, decimals=9), "tracked HIP (or the HIP a scenario holds)"),
    Field("proxy", vec(3, POS, decimals=9), "centre of the god-object proxy sphere of radius `hip.proxy_radius` "
          "(never closer than that to a touchable object's surface); equals `hip` when free"),
    Field("force", vec(3, POS, decimals=6), "k·(proxy − HIP), newtons (notional for trackers)"),
    Field("contact", boolean(), "debounced contact (hysteresis)"),
    Field("contacts", array(_CONTACT, "array of `[object_id, [nx, ny, nz], depth]`"),
          "raw god-object contacts this tick: the scene's object id, the outward unit normal and the depth "
          "(\"Contacts\" below)"),
    Field("objects", array(_POSE, "array of `[object_id, [x, y, z], [w, x, y, z]]`"),
          "poses of every object that moved since the scene was sent (the complete set; empty for static scenes)"),
    Field("cues", array(mapping(doc="cue"), "array of cue maps"),
          'active device-independent cues ("Cues" below), e.g. `{"kind": "tilt", "direction_deg": 90, '
          '"magnitude_pct": 100}`'),
    Field("hud", string(), "text the scenario shows now; when empty, clients show the scene's `hud.text`"),
    Field("values", mapping(), 'scenario values worth showing or recording (e.g. `{"angle_deg": -12.5}`)'),
    Field("telemetry", mapping(), "loop timing over the last 10 s: `period_p50_us, period_p99_us, period_max_us, "
          "overruns` (periods > 1.5 ms), `tick_cost_p99_us, ticks` (total), `rt` (real-time priority held); "
          "all 0 until the first ticks are in"),
    Field("visible", mapping(boolean(), "map id → bool"), "visibility overrides of objects and overlays against "
          "the scene (the complete current set; an id not in it has its scene `visible`), e.g. "
          '`{"angle_scale": false}` in a main trial', required=False),
    Field("events", array(mapping(doc="event"), "array of maps"), 'scenario events since the previous frame this '
          'client was sent (a frame it missed gives its events to the next one), each once: `{"tick", "t", "name", …}`, e.g. `{"tick": 20010, "t": 20.01, "name": "key", "key": "ArrowUp", '
          '"right_level": 7}`', required=False),
    Field("scales", mapping(vec(3, "`[sx, sy, sz]`"), "map id → `[sx, sy, sz]`"), "objects drawn scaled along the "
          "scene axes (the complete current set; an id not in it has its scene size), e.g. the positioning "
          "task's widened holes; drawing only, never collision", required=False),
    Field("stiffness", mapping(number(min=0), "map id → k"), "spring constants in N/m that differ from the scene's "
          "`material.stiffness_n_per_m` (the complete current set; an id not in it has its scene stiffness)",
          required=False, since=1),
    Field("haptic", mapping(boolean(), "map id → bool"), "touchability overrides against the scene's `haptic` "
          "(the complete current set; an id not in it has its scene `haptic`)", required=False, since=1),
    Field("driver", any_of(null(), _DRIVER, doc="`[client_id, seq]` \\| null"), "the source whose tracker "
          "samples drive the HIP and the `seq` of its last applied sample, or null when nobody drives it "
          "(\"Tracker rule\" below); `client_id` is the welcome's int id of a /ws client, or "
          '`"udp:HOST:PORT"` for a UDP tracker bridge', required=False, since=1),
    Field("tools", array(_TOOL, "array of `{name, hip, proxy, contact, lost}`"), "every tool (a tracked point "
          "and its god-object), primary first: `name` the point that drives it, `hip` and `proxy` `[x, y, z]` (9 "
          "decimals), debounced `contact`, `lost` (its tracker source stopped: the tool is home and out of "
          "contact). `hip`, `proxy` and `contact` above are the primary tool's", required=False, since=4),
    Field("points", mapping(vec(3, POS, decimals=9), "map point name → `[x, y, z]`", keys=POINT_NAME),
          "the latest tracked points that drive no tool (a hand's other joints, for drawing); `{}` when none",
          required=False, since=4),
    Field("tracking", mapping(doc="map `{lost}`"), "`{\"lost\": [source, …]}`: the tracker sources lost right "
          "now (\"Tracker loss\"), each a `client_id` as in `driver`", required=False, since=4),
    Field("actuator", fixed([number(0, 1, doc="value"), number(min=0, doc="on_ms"),
                             number(min=0, doc="off_ms"), number(min=0, doc="duration_ms"),
                             integer(min=0, doc="onset")], "`[value, on_ms, off_ms, duration_ms, onset]`"),
          "what a participant page's actuators play now (only when the rig has a `browser` device; \"Browser "
          "actuators\" below): amplitude `value` (0..1, 0 = off), continuous (`off_ms` 0) or `on_ms` on and "
          "`off_ms` off repeated, for `duration_ms` from the tick `onset` (0: until the next drive); the primary "
          "tool's cues encoded by the server for the browser profile", required=False, since=6),
))

ERROR = Message("error", "server_to_client", "", (
    _type("error"),
    Field("code", string(min_len=1), "one of the codes below (a client treats a code it does not know as a "
          "generic error)"),
    Field("message", string(max_len=MAX_ERROR_MESSAGE_CHARS), "a sentence for a person; a value it quotes from "
          "the client is cut to 64 characters"),
))

HEALTH_STATUSES = ("ok", "degraded", "starting")

HEALTH = Message("health", "server_to_client", "after `welcome` and the first `scene`, and whenever the server's "
                 "health status or the set of reason codes changes", (
    _type("health"),
    Field("status", enum(HEALTH_STATUSES), "`ok`; `degraded` while any reason holds (clients tell the user: the "
          "console a banner, the participant's HUD that tactile feedback is paused); `starting` before the haptic "
          "loop's first tick", since=2),
    Field("reasons", array(mapping(string(), "map `{code, message}`"), "array of `{code, message}`"),
          "why it is not `ok`: `code` is one of `loop_down`, `loop_stalled`, `tick_failures`, `device_missing`, "
          "`device_host_down`, `device_host_restarted`, `overruns`, `tracker_lost` (v1.4; a client treats a code it "
          "does not know like any other); `message` is a sentence for a person, e.g. \"device 'ferrovibe' is disconnected: check its "
          "cable and power; the running scenario 'contact-angle' needs it for macro-roughness (tilt)\". "
          "`GET /api/health` lists the same reasons", since=2),
))

_LEASE_HOLDER = mapping(doc="map `{token_id, role, site, label, since, expires_at}`")
_LEASE_QUEUED = mapping(doc="map `{token_id, role, site, label, position}`")

LEASE = Message("lease", "server_to_client", "after `welcome`, `scene` and `health`, and whenever the control lease "
                "changes", (
    _type("lease"),
    Field("holder", any_of(null(), _LEASE_HOLDER, doc="map \\| null"), "who controls the rig now, or null: "
          "`token_id`, `role`, `site`, `label`, `since` and `expires_at` (UTC seconds; renewing moves it)", since=3),
    Field("queue", array(_LEASE_QUEUED, "array of maps"), "who waits for it, first in line first: `token_id`, "
          "`role`, `site`, `label`, `position` (1 = next)", since=3),
    Field("session", _OPT_STRING, "the participant session the holder opened: a participant token of this "
          "session may drive the HIP; null when none is open", since=3),
    Field("ttl_s", number(min=0, min_exclusive=True), "seconds without a renewal after which the holder (or a "
          "queued requester) loses its place", since=3),
))

_ASKED = mapping(doc="map `{id, kind, text, low, high, integer, labels, choices, required, answer}`")
_AUDIO = mapping(boolean(), "map `{speech, contact_sounds}`")
_PACING = mapping(doc="map `{state, done, total, feedback}`")

ASK = Message("ask", "server_to_client", "to a participant connection of a session (its token's `session`): after "
              "`welcome` and whenever the session's running trial, its answers or its audio change", (
    _type("ask"),
    Field("session", string(min_len=1), "the participant's session", since=5),
    Field("seq", any_of(null(), integer(min=0), doc="int ≥ 0 \\| null"), "the running trial, or null when none "
          "runs", since=5),
    Field("task", _OPT_STRING, "the task of the running trial, else of the next pending one (null: none)", since=5),
    Field("questions", array(_ASKED, "array of maps"), "the running trial's questions the participant answers "
          "(study `answered_by = \"participant\"`), in the study's order: the question as in the study file "
          "(docs/studies.md \"Question\") and `answer`, the recorded value or null; `[]` when none", since=5),
    Field("audio", _AUDIO, "what the page plays for this task (the study's `[audio]`): `speech` speaks each new "
          "instruction, `contact_sounds` clicks at each contact onset; both false unless the study turns them on",
          since=5),
    Field("instructions", string(), "the task's `instructions` (empty when none)", since=5),
    Field("pacing", any_of(null(), _PACING, doc="map \\| null"), "a participant-paced task (study "
          "`[tasks.pacing]`, docs/studies.md \"Participant-paced tasks\"), else null: `state` is `trial` (answer "
          "now), `next` (the next trial starts after the inter-trial interval), `feedback` (`feedback` is "
          "`\"correct\"` or `\"wrong\"`, else null), `break` (the next trial waits until the participant sends "
          "`answer` with `question` `\"pacing:continue\"`, `seq` 0 and `value` 1: neither is read), `paused` "
          "(by the experimenter) or `experimenter` (the experimenter starts the task, or goes on after a restart); "
          "`done` and `total`: the task's ended and planned trials", required=False, since=6),
))

MESSAGES: dict[str, Message] = {m.name: m for m in (HELLO, TRACKER, INPUT, ANSWER, ACTUATORS, WELCOME, SCENE, STATE,
                                                    ERROR, HEALTH, LEASE, ASK)}
CLIENT_MESSAGE_NAMES = tuple(name for name, m in MESSAGES.items() if m.direction == "client_to_server")

ERROR_CODES: dict[str, str] = {
    "bad_encoding": "not msgpack / not JSON, or a JSON frame on a msgpack connection and vice versa",
    "bad_message": "not a map, no `type`, or a field of the wrong type / shape / range",
    "non_finite": "NaN or ±Infinity in a number",
    "unknown_type": "a `type` the server does not know",
    "too_large": "a frame over 64 KiB",
    "forbidden": "the role, the site or the control lease does not allow this message (or the role asked for in "
                 "`hello`: the welcome then grants a lower one)",
    "unauthorized": "no valid token: `hello` without a token, with an unknown, expired or revoked one, or no "
                    "`hello` within the grace period (the connection then closes, code 1008); or the token was "
                    "revoked or expired while connected (the connection then closes, code 1008 with the close "
                    "reason `revoked` or `expired`: a client says why and does not reconnect with that token)",
    "session_closed": "to a participant connection: its session is no longer the one the lease holder has open "
                      "(released, expired, handed over); it may not drive until `lease.session` names it again",
    "session_taken": "to a participant connection: another connection of its session (a second tab or device) "
                     "was welcomed and drives now; this one only watches (a reload takes the session back)",
    "unsupported_version": "`hello.v` is not 1 (the connection then closes)",
    "busy": "the loop's input mailbox is full; the message was dropped",
    "out_of_range": "a finite number beyond the protocol's bounds: an integer outside ±(2^53 − 1), a tracker "
                    "`pos` outside the workspace, a `t` beyond ±(2^53 − 1) ms (\"Bounds\")",
    "conflict": "an `answer` to a trial that is not running (any more), or to a question it does not ask; a break's "
                "`pacing:continue` when no break is held",
    "rate_limited": "the client sent `input` faster than its budget (\"Input budget\"); the message was dropped "
                    "(at most one such error a second); or the token already has 256 connections open (the "
                    "connection then closes, code 1008)",
}

# One line per cue kind for the docs (fields, units and ranges come from server/core/cues.py).
CUE_MEANINGS: dict[str, str] = {
    "pulse_train": "bursts of vibration: `t_on_ms` on, `t_off_ms` off, repeated",
    "vibration": "continuous vibration",
    "texture": "fine roughness as a periodic signal: one period of `period_us`, on for the fraction `duty`",
    "tilt": "a tilt of the fingerpad contact: 0 = front of the fingerpad, 90 = right, 180 = back, 270 = left",
    "stiffness": "how hard the touched object is: spring constant `k_n_per_m`, and `relative` between the "
                 "softest (0) and the stiffest (1) object of the task",
    "temperature": "surface temperature",
    "friction": "friction coefficient of the touched surface",
    "stop": "every actuator off now, whatever else the frame lists",
}


def schema_json() -> dict:
    """The declaration as JSON-able data: what the browser client's checker reads."""
    return {"protocol": {"v": PROTOCOL_VERSION, "minor": PROTOCOL_MINOR, "scene_format": SCENE_FORMAT_VERSION},
            "messages": [m.to_json() for m in MESSAGES.values()], "error_codes": list(ERROR_CODES)}
