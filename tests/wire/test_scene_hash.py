"""The scene hash, recomputed from docs/protocol.md's recipe ("Scene hash") by an implementation of
its own here (shortest digits found by trying precisions, UTF-16 order and string escapes spelt
out), against the shared vectors, the server's Scene.hash and the core's canonical JSON."""

import hashlib
import json
import struct
from pathlib import Path

import msgpack
import pytest

from scenarios.registry import SCENARIOS
from server.core.canonical_json import canonical_json, es_number
from server.core.scene import Scene
from server.wire import codec

VECTORS = Path(__file__).parents[1] / "vectors"
HASHES = json.loads((VECTORS / "scene_hash.json").read_text(encoding="utf-8"))
MESSAGES = json.loads((VECTORS / "messages.json").read_text(encoding="utf-8"))["vectors"]
SHORT_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def recipe_number(x: float) -> str:
    """Step 3's numbers: ECMAScript's Number::toString of a float64."""
    if x == 0:
        return "0"
    if x < 0:
        return "-" + recipe_number(-x)
    for precision in range(1, 18):  # the shortest digits that read back to x
        mantissa, exponent = f"{x:.{precision - 1}e}".split("e")
        if float(f"{mantissa}e{exponent}") == x:
            break
    digits = mantissa.replace(".", "").rstrip("0")
    k, n = len(digits), int(exponent) + 1  # x = 0.digits * 10**n
    if k <= n <= 21:
        return digits + "0" * (n - k)
    if 0 < n <= 21:
        return f"{digits[:n]}.{digits[n:]}"
    if -6 < n <= 0:
        return "0." + "0" * -n + digits
    return f"{digits[0]}{'.' + digits[1:] if k > 1 else ''}e{'+' if n - 1 >= 0 else '-'}{abs(n - 1)}"


def utf16_units(key: str) -> list[int]:
    units = []
    for ch in key:
        cp = ord(ch)
        if cp < 0x10000:
            units.append(cp)
        else:
            cp -= 0x10000
            units += [0xD800 + (cp >> 10), 0xDC00 + (cp & 0x3FF)]
    return units


def recipe_string(s: str) -> str:
    return '"' + "".join(SHORT_ESCAPES.get(c, f"\\u{ord(c):04x}" if ord(c) < 0x20 else c) for c in s) + '"'


def recipe_json(v) -> str:
    """Steps 2 and 3: canonical numbers, then RFC 8785 text."""
    if v is None or isinstance(v, bool):
        return {None: "null", True: "true", False: "false"}[v]
    if isinstance(v, (int, float)):
        if float(v).is_integer() and abs(v) < 2**53:
            return str(int(v))  # step 2: integral below 2**53 is an integer
        return recipe_number(float(v))
    if isinstance(v, str):
        return recipe_string(v)
    if isinstance(v, list):
        return "[" + ",".join(recipe_json(x) for x in v) + "]"
    keys = sorted(v, key=utf16_units)
    return "{" + ",".join(recipe_string(k) + ":" + recipe_json(v[k]) for k in keys) + "}"


def recipe_hash(scene: dict) -> str:
    return hashlib.sha256(recipe_json(scene).encode("utf-8")).hexdigest()[:16]


@pytest.mark.parametrize("case", HASHES["cases"], ids=lambda c: c["name"])
def test_vector_cases_follow_the_recipe(case):
    assert recipe_json(case["value"]) == case["canonical"]
    assert canonical_json(case["value"]) == case["canonical"]
    assert recipe_hash(case["value"]) == case["hash"]


@pytest.mark.parametrize("number", HASHES["numbers"], ids=lambda n: n["bits"])
def test_numbers_are_spelt_as_ecmascript_does(number):
    x = struct.unpack(">d", bytes.fromhex(number["bits"]))[0]
    assert recipe_number(x) == number["canonical"]
    assert es_number(x) == number["canonical"]


@pytest.mark.parametrize("vector", [v for v in MESSAGES if v["type"] == "scene"], ids=lambda v: v["name"])
def test_scene_messages_carry_the_hash_of_their_scene(vector):
    scene = vector["message"]["scene"]
    assert recipe_hash(scene) == vector["message"]["hash"]
    assert Scene.from_dict(scene).hash == vector["message"]["hash"]
    states = [v["message"] for v in MESSAGES if v["type"] == "state"]
    assert all(s["scene"] in {v["message"]["hash"] for v in MESSAGES if v["type"] == "scene"} for s in states)


@pytest.mark.parametrize("spec", SCENARIOS.values(), ids=lambda s: s.id)
def test_a_client_recomputes_every_scenario_hash_from_the_frame_it_received(spec):
    scene = spec.factory().build_scene()
    message = {"type": "scene", "v": 1, "hash": scene.hash, "scene": scene.to_dict()}
    for fmt in codec.FORMATS:
        received = codec.decode(codec.encode(message, fmt), fmt)
        assert recipe_hash(received["scene"]) == scene.hash, fmt
    # the hash does not depend on whether the scenario wrote 1 or 1.0
    assert Scene.from_dict(msgpack.unpackb(msgpack.packb(codec.canonical(scene.to_dict())))).hash == scene.hash


def test_recipe_spot_checks():
    assert recipe_json({"b": 1.0, "a": [0.5, -0.0, 1e-7, 1e21]}) == '{"a":[0.5,0,1e-7,1e+21],"b":1}'
    assert recipe_json({"z": "\u00e9\x1f"}) == '{"z":"\u00e9\\u001f"}'
