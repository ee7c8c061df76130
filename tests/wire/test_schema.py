"""The declaration (server/wire/schema.py) against everything that follows from it: the docs
tables, the browser client's schema module, the builders, the parsers, the shared vectors, the
cue classes and the loop's rounding."""

import json
import math
from dataclasses import fields
from pathlib import Path

import pytest

from scenarios.contact_angle import ContactAngle
from server.core.cues import CUE_CLASSES, CUE_KINDS, cue_to_wire
from server.loop.tick import Loop
from server.loop.simulation import Simulation
from server.wire import doc, messages
from server.wire.check import check_message
from server.wire.codec import WireError, decode, encode
from server.wire.schema import CUE_MEANINGS, ERROR_CODES, MESSAGES, STATE
from server.ipc.records import TrackerSample
from tests.ipc import state_map

VECTORS = Path(__file__).parents[1] / "vectors"
MESSAGE_FILE = json.loads((VECTORS / "messages.json").read_text(encoding="utf-8"))
INVALID_FILE = json.loads((VECTORS / "invalid.json").read_text(encoding="utf-8"))
VALID = MESSAGE_FILE["vectors"]
RECEIVED = MESSAGE_FILE["received"]
TELEMETRY = {"period_p50_us": 1000, "period_p99_us": 1010, "period_max_us": 1100, "overruns": 0,
             "tick_cost_p99_us": 30, "ticks": 5, "rt": False}


# ---- generated outputs ----------------------------------------------------------------------

def test_docs_tables_are_the_declaration():
    written = doc.doc_blocks(doc.DOC.read_text(encoding="utf-8"))
    assert set(written) == set(doc.TABLES), "docs/protocol.md lacks or has extra generated blocks"
    for key, render in doc.TABLES.items():
        assert written[key] == render(), f"docs/protocol.md '{key}' differs: run python -m server.wire.doc"


def test_docs_check_fails_when_a_table_disagrees(tmp_path, monkeypatch):
    text = doc.DOC.read_text(encoding="utf-8")
    assert doc.render_doc(text) == text
    edited = text.replace("| `seq` | int ≥ 0 |", "| `seq` | int |", 1)
    assert edited != text and doc.render_doc(edited) == text
    monkeypatch.setattr(doc, "DOC", tmp_path / "protocol.md")
    monkeypatch.setattr(doc, "SCHEMA_JS", tmp_path / "schema.js")
    doc.DOC.write_text(edited, encoding="utf-8")
    doc.SCHEMA_JS.write_text(doc.render_schema_js(), encoding="utf-8")
    assert doc.main(["--check"]) == 1
    assert doc.main([]) == 0 and doc.DOC.read_text(encoding="utf-8") == text
    assert doc.main(["--check"]) == 0


def test_browser_schema_module_is_the_declaration():
    assert doc.SCHEMA_JS.read_text(encoding="utf-8") == doc.render_schema_js(), \
        "clients/web/src/schema.js differs from server/wire/schema.py: run python -m server.wire.doc"
    body = doc.SCHEMA_JS.read_text(encoding="utf-8").split("export const SCHEMA = ", 1)[1].rstrip().rstrip(";")
    declared = json.loads(body)
    assert [m["name"] for m in declared["messages"]] == list(MESSAGES)
    assert declared["error_codes"] == list(ERROR_CODES)


# ---- builders and parsers follow the declaration ----------------------------------------------

def _order(name):
    return [f.name for f in MESSAGES[name].fields]


def test_builders_write_the_declared_fields_in_order_and_pass_the_checks():
    built = {
        "welcome": messages.welcome(3, "observer", "viestac/test", 1000, 60.0, "json",
                                    {"token_id": "0b7e41aa", "role": "admin", "site": None, "label": "env"}),
        "scene": messages.scene_message({"name": "x"}, "0123456789abcdef"),
        "error": messages.error("busy", "full"),
        "lease": messages.lease({"holder": None, "queue": [], "session": None, "ttl_s": 60.0}),
    }
    for name, message in built.items():
        assert list(message) == _order(name)
        check_message(message)
    assert built["welcome"]["minor"] == 6  # v1.6 (was 5)
    # the welcome says who the token is, never more (no label, no secret)
    assert built["welcome"]["identity"] == {"token_id": "0b7e41aa", "role": "admin", "site": None, "session": None}


def _record(**extra):
    record = {"frame": 4, "tick": 66, "t": 12.5, "scene": "0123456789abcdef", "hip": [0.0, 0.1, 0.2],
              "proxy": [0.0, 0.1, 0.25], "force": [0.0, 0.0, 0.05], "contact": True,
              "contacts": [["dome", [0.0, 0.0, 1.0], 0.05]], "objects": [["cube", [1.0, 0.0, 0.0], [1.0, 0, 0, 0]]],
              "cues": [{"kind": "stop"}], "hud": "", "values": {"a": 1}, "visible": {"dome": False},
              "events": [], "scales": {"dome": [1.0, 2.0, 1.0]}, "stiffness": {"dome": 300.0}, "haptic": {"x": False},
              "driver": [3, 17], "tools": [], "points": {}, "tracking": {"lost": []},
              # loop-internal keys stay behind
              "samples": b"\0" * 16, "trackers": [[3, 17, 0.0, 1, 2]], "trajectory": [], "resyncs": 0,
              "finished": []}
    record.update(extra)
    return record


def test_state_message_picks_the_declared_fields_from_the_loop_record():
    message = messages.state_message(_record(), TELEMETRY, [0.6, 100.0, 200.0, 0.0, 60])
    assert list(message) == _order("state")
    assert message["telemetry"] is TELEMETRY and message["driver"] == [3, 17]
    check_message(decode(encode(message)))
    # v1.6: the hub adds `actuator` only on a rig with a browser device; the loop's view never has it
    plain = messages.state_message(_record(), TELEMETRY)
    assert list(plain) == [name for name in _order("state") if name != "actuator"]
    check_message(decode(encode(plain)))


def test_state_message_names_a_field_the_view_lacks():
    record = _record()
    del record["scene"]
    with pytest.raises(KeyError, match="'scene'"):
        messages.state_message(record, TELEMETRY)


def test_integer_fields_take_integral_floats_and_refuse_others():
    body = {"type": "tracker", "seq": 3.0, "t": 1, "pos": [0, 0, 0]}
    tracker = messages.parse_client_message(body)
    assert tracker.seq == 3 and type(tracker.seq) is int
    for seq in (2.5, -1.0, True, "3"):
        with pytest.raises(WireError) as info:
            messages.parse_client_message({**body, "seq": seq})
        assert info.value.code == "bad_message" and "'seq'" in info.value.message
    # Issue 18: an integer beyond ±(2^53 − 1) is out of the protocol's bounds (it was bad_message)
    with pytest.raises(WireError) as info:
        messages.parse_client_message({**body, "seq": 2.0**53})
    assert info.value.code == "out_of_range" and "'seq'" in info.value.message
    assert messages.parse_client_message({"type": "hello", "v": 1.0, "role": "observer"}).version == 1


def test_tracker_quaternion_is_normalised_within_its_norm_range():
    body = {"type": "tracker", "seq": 1, "t": 0, "pos": [0, 0, 0]}
    for q, unit in (([0, 0, 1.5, 0], (0, 0, 1, 0)), ([0.5, 0, 0, 0], (1, 0, 0, 0)), ([1, 1, 1, 1], (0.5,) * 4)):
        assert messages.parse_client_message({**body, "quat": q}).quat == pytest.approx(unit, abs=1e-15)
    for q in ([0, 0, 0, 0], [0.49, 0, 0, 0], [2.01, 0, 0, 0], [1e-300, 0, 0, 0]):
        with pytest.raises(WireError) as info:
            messages.parse_client_message({**body, "quat": q})
        assert info.value.code == "bad_message"
    with pytest.raises(WireError) as info:
        messages.parse_client_message({**body, "quat": [math.nan, 0, 0, 1]})
    assert info.value.code == "non_finite"


# ---- the shared vectors cover the declaration ----------------------------------------------------

def test_vectors_cover_every_message_and_field_in_both_directions():
    for name, message in MESSAGES.items():
        of_type = [v for v in VALID if v["type"] == name]
        assert of_type, f"no valid vector for {name}"
        assert all(v["direction"] == message.direction for v in of_type)
        for f in message.fields:
            assert any(f.name in v["message"] for v in of_type), f"no vector has {name}.{f.name}"
        refused = INVALID_FILE["frames" if message.direction == "client_to_server" else "server_frames"]
        assert any(name in r["name"].split("-")[0] for r in refused), f"no invalid vector for {name}"
    assert {v["type"] for v in RECEIVED} >= {"hello", "tracker", "input", "welcome", "state"}
    codes = {f["code"] for f in INVALID_FILE["frames"] + INVALID_FILE["server_frames"]}
    assert codes <= set(ERROR_CODES)


@pytest.mark.parametrize("vector", VALID, ids=lambda v: v["name"])
def test_valid_vectors_pass_the_declared_checks_in_declared_order(vector):
    message = vector["message"]
    check_message(message)
    declared = [n for n in _order(vector["type"]) if n in message]
    assert list(message) == declared
    assert encode(message, "json") == vector["json"]
    assert decode(vector["json"], "json") == message


def _close(got, want):
    if isinstance(want, float) or isinstance(got, float):
        return math.isclose(got, want, rel_tol=0, abs_tol=1e-12)
    if isinstance(want, list):
        return len(got) == len(want) and all(_close(g, w) for g, w in zip(got, want))
    if isinstance(want, dict):
        return got.keys() == want.keys() and all(_close(got[k], want[k]) for k in want)
    return got == want and type(got) is type(want)


@pytest.mark.parametrize("vector", RECEIVED, ids=lambda v: v["name"])
def test_received_vectors_are_accepted_as_their_expected_message(vector):
    for fmt, frame in (("msgpack", bytes.fromhex(vector["msgpack_hex"])), ("json", vector["json"])):
        body = decode(frame, fmt)
        if vector["direction"] == "client_to_server":
            got = messages.parse_client_message(body).to_wire()
        else:
            checked = check_message(body)
            got = {"type": body["type"], **{k: v for k, v in checked.items() if k in body}}
        assert _close(json.loads(json.dumps(got)), vector["expect"]), (fmt, got)


@pytest.mark.parametrize("frame", [f for f in INVALID_FILE["frames"] if f["json"] is not None],
                         ids=lambda f: f["name"])
def test_invalid_client_frames_in_json_get_the_same_code(frame):
    with pytest.raises(WireError) as info:
        messages.parse_client_message(decode(frame["json"], "json"))
    assert info.value.code == frame["code"]


@pytest.mark.parametrize("frame", INVALID_FILE["server_frames"], ids=lambda f: f["name"])
def test_invalid_server_frames_are_refused_with_their_code(frame):
    encodings = [("msgpack", bytes.fromhex(frame["msgpack_hex"]))]
    if frame["json"] is not None:
        encodings.append(("json", frame["json"]))
    for fmt, data in encodings:
        with pytest.raises(WireError) as info:
            check_message(decode(data, fmt))
        assert info.value.code == frame["code"], (fmt, info.value.message)


# ---- cues and rounding ----------------------------------------------------------------------------

def test_cue_table_covers_every_kind_and_cue_to_wire_writes_the_documented_fields():
    assert set(CUE_MEANINGS) == set(CUE_KINDS)
    table = doc.cues_table()
    for cls in CUE_CLASSES:
        names = [f.name for f in fields(cls)]
        assert set(cls.RANGES) == set(names), cls.kind
        optional = [f.name for f in fields(cls) if f.default is None]
        bare = cue_to_wire(cls())
        assert list(bare) == ["kind"] + [n for n in names if n not in optional]
        full = cue_to_wire(cls(**{n: cls.RANGES[n][1] for n in optional}))
        assert list(full) == ["kind"] + names and full["kind"] == cls.kind
        for n in names:
            low, high = cls.RANGES[n]
            assert low <= full[n] <= high
            assert f"| `{n}` |" in table


def _decimals_ok(value, decimals):
    return round(value, decimals) == value


def test_the_loop_rounds_the_documented_fields_to_the_documented_places():
    core = Loop(Simulation(ContactAngle()))
    for t in range(50):
        core.step(t * 1_000_000)
    # an odd point inside the dome's top, so contact, force and normal have many digits
    core.apply(TrackerSample(1, 0, 0.0, [0.0123456789123, -0.1234567891234, 0.6112345678912], None, 0), 0)
    record = None
    for t in range(50, 200):
        record = state_map(core.step(t * 1_000_000)[1]) or record
    assert record is not None and record["contacts"], "the probe point must be in contact"
    rounded = dict((path, d) for path, d in (
        (r.split("|")[1].strip().strip("`"), int(r.split("|")[3])) for r in doc.rounding_table().splitlines()[2:]))
    assert rounded == {"state.hip": 9, "state.proxy": 9, "state.force": 6, "state.contacts[n][1]": 6,
                       "state.contacts[n][2]": 9, "state.objects[n][1]": 9, "state.objects[n][2]": 9}
    for name in ("hip", "proxy", "force"):
        decimals = STATE.field(name).type["decimals"]
        assert all(_decimals_ok(x, decimals) for x in record[name]), name
    assert any(not _decimals_ok(x, 8) for x in record["hip"] + record["proxy"])  # the probe had digits to lose
    for _, normal, depth in record["contacts"]:
        assert all(_decimals_ok(x, 6) for x in normal) and _decimals_ok(depth, 9)


@pytest.mark.parametrize("field", ["t", "pos"])
def test_an_integer_too_long_for_a_float_is_refused_as_non_finite_not_raised(field):
    """JSON allows integers of any length; float() of a 400-digit one raises OverflowError."""
    huge = int("9" * 400)
    body = {"type": "tracker", "seq": 1, "t": 1, "pos": [0, 0, 0]}
    body[field] = huge if field == "t" else [0, huge, 0]
    with pytest.raises(WireError) as caught:
        messages.parse_client_message(decode(json.dumps(body), "json"))
    assert caught.value.code == "non_finite"
