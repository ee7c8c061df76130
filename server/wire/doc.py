"""The outputs that follow from the declaration (schema.py): the tables of docs/protocol.md and the
browser client's schema module (clients/web/src/schema.js).

    python -m server.wire.doc           # rewrite both
    python -m server.wire.doc --check   # exit 1 if either is stale (tests/wire/test_schema.py too)

In docs/protocol.md each generated table sits between `<!-- generated: KEY -->` and
`<!-- end generated -->`; the text around it is written by hand. Keys: `message NAME` for each
message, `errors`, `cues`, `rounding` and `scene hash example`.
"""

from __future__ import annotations

import hashlib
import json
import re
import sys
from dataclasses import fields
from pathlib import Path

from server.core.canonical_json import canonical_json, es_number
from server.core.cues import CUE_CLASSES
from server.core.scene import Scene
from server.wire.schema import CUE_MEANINGS, ERROR_CODES, MESSAGES, PROTOCOL_MINOR, schema_json

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "protocol.md"
SCHEMA_JS = ROOT / "clients" / "web" / "src" / "schema.js"
_BLOCK = re.compile(r"(<!-- generated: (?P<key>[^>]+?) -->\n)(?P<body>.*?)(<!-- end generated -->)", re.S)
_UNITS = (("_ms", "ms"), ("_us", "µs"), ("_pct", "%"), ("_hz", "Hz"), ("_deg", "degrees"), ("_n_per_m", "N/m"),
          ("celsius", "°C"))


def _num(x: float) -> str:
    return es_number(float(x)) if isinstance(x, float) else str(x)


def message_table(name: str) -> str:
    message = MESSAGES[name]
    rows = ["| field | type | meaning |", "|---|---|---|"]
    for f in message.fields:
        kind = f.type["doc"] + ("" if f.required else " (optional)")
        meaning = (f"**v1.{f.since}.** " if f.since else "") + f.meaning
        rows.append(f"| `{f.name}` | {kind} | {meaning} |")
    return "\n".join(rows) + "\n"


def errors_table() -> str:
    rows = ["| code | when |", "|---|---|"]
    rows += [f"| `{code}` | {when} |" for code, when in ERROR_CODES.items()]
    return "\n".join(rows) + "\n"


def _unit(name: str) -> str:
    return next((unit for suffix, unit in _UNITS if name.endswith(suffix)), "—")


def cues_table() -> str:
    rows = ["| `kind` | field | unit | range | sent | meaning |", "|---|---|---|---|---|---|"]
    for cls in CUE_CLASSES:
        first = f"`{cls.kind}`"
        meaning = CUE_MEANINGS[cls.kind]
        cue_fields = fields(cls)
        if not cue_fields:
            rows.append(f"| {first} | — | | | | {meaning} |")
        for f in cue_fields:
            low, high = cls.RANGES[f.name]
            sent = "when given" if f.default is None else "always"
            rows.append(f"| {first} | `{f.name}` | {_unit(f.name)} | [{_num(low)}, {_num(high)}] | {sent} | "
                        f"{meaning} |")
            first, meaning = "", ""
    return "\n".join(rows) + "\n"


def _rounded(t: dict, path: str):
    if "decimals" in t:
        yield path, t["decimals"]
    for i, item in enumerate(t.get("items", []) if t["kind"] == "tuple" else []):
        yield from _rounded(item, f"{path}[{i}]")
    if t["kind"] == "array":
        yield from _rounded(t["items"], f"{path}[n]")


def rounding_table() -> str:
    rows = ["| field | what | decimal places |", "|---|---|---|"]
    for message in MESSAGES.values():
        for f in message.fields:
            for path, decimals in _rounded(f.type, f.name):
                what = _path_doc(f.type, path[len(f.name):])
                rows.append(f"| `{message.name}.{path}` | {what} | {decimals} |")
    return "\n".join(rows) + "\n"


def _path_doc(t: dict, rest: str) -> str:
    """The doc of the type at `rest` (e.g. "[n][1]") inside `t`."""
    for step in re.findall(r"\[(\w+)\]", rest):
        t = t["items"] if step == "n" else t["items"][int(step)]
    return t["doc"]


# The docs' scene hash example: a small scene as a scenario would build it (1.0, not 1).
_EXAMPLE_SCENE = {
    "name": "demo", "camera": {"projection": "orthographic", "position": [5.0, 0.0, 0.35],
                               "target": [0.0, 0.0, 0.35], "up": [0.0, 0.0, 1.0], "height": 1.6},
    "hip": {"radius": 0.06, "proxy_radius": 0.06, "color": "#ffd400"},
    "objects": [{"id": "dome", "shape": {"type": "hemisphere", "radius": 0.6},
                 "pose": {"pos": [0.0, 0.0, 0.0], "quat": [1.0, 0.0, 0.0, 0.0]},
                 "material": {"color": "#3a7bd5", "stiffness_n_per_m": 1000.0}}],
    "hud": {"text": "Berühre die Halbkugel"},
}


def scene_hash_example() -> str:
    scene = Scene.from_dict(_EXAMPLE_SCENE)
    text = canonical_json(scene.to_dict())
    assert hashlib.sha256(text.encode("utf-8")).hexdigest()[:16] == scene.hash
    return (f"The scene map `Scene.from_dict` makes of `{_EXAMPLE_SCENE['name']}` (defaults filled in), "
            "as canonical JSON:\n\n"
            f"```json\n{text}\n```\n\nits hash: `{scene.hash}`.\n")


TABLES = {**{f"message {name}": (lambda name=name: message_table(name)) for name in MESSAGES},
          "errors": errors_table, "cues": cues_table, "rounding": rounding_table,
          "scene hash example": scene_hash_example}


def render_doc(text: str) -> str:
    """`text` (docs/protocol.md) with every generated block rewritten; KeyError for an unknown key."""
    def block(m: re.Match) -> str:
        return m.group(1) + TABLES[m.group("key")]() + m.group(4)
    return _BLOCK.sub(block, text)


def doc_blocks(text: str) -> dict[str, str]:
    """The generated blocks of `text` as written: key -> body."""
    return {m.group("key"): m.group("body") for m in _BLOCK.finditer(text)}


def render_schema_js() -> str:
    body = json.dumps(schema_json(), indent=1, ensure_ascii=False)
    return ("// Generated by `python -m server.wire.doc` from server/wire/schema.py; do not edit.\n"
            f"// The messages of protocol v1.{PROTOCOL_MINOR}, declared once (docs/protocol.md); "
            "protocol.js checks messages against it.\n"
            f"export const SCHEMA = {body};\n")


def main(argv: list[str]) -> int:
    check = "--check" in argv
    doc = DOC.read_text(encoding="utf-8")
    missing = set(TABLES) - set(doc_blocks(doc))
    if missing:
        print(f"{DOC}: no generated block for {', '.join(sorted(missing))}", file=sys.stderr)
        return 1
    outputs = {DOC: render_doc(doc), SCHEMA_JS: render_schema_js()}
    stale = [path for path, text in outputs.items()
             if not path.exists() or path.read_text(encoding="utf-8") != text]
    if check:
        for path in stale:
            print(f"{path} is stale: run python -m server.wire.doc", file=sys.stderr)
        return 1 if stale else 0
    for path in stale:
        path.write_text(outputs[path], encoding="utf-8")
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
