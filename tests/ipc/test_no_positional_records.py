"""No record between the processes is read, built or dispatched by position outside its
declaration (server/ipc/records.py): every process boundary goes through the typed records.

Scanned (the syntax tree, not the text): every Python file under server/ and devices/, except
- server/ipc/records.py, the declarations' own to/from array code;
- server/bench/, `viestac bench`: it measures the channels with raw byte blobs of record size
  (floor.py), never decodes a record, and is a user command, not a process boundary of the server.
Found: `record[1]` / `rec[0]` (an int index on a name that holds a record), a list built with a
record's tag first (`["log", "error", text]`; a list of string constants only, such as a table's
column names, is not a record), and a tag compared at index 0 (`x[0] == "state"`).
"""

import ast
from pathlib import Path

from server.ipc.records import CHANNELS

ROOT = Path(__file__).resolve().parents[2]
EXCLUDED = {ROOT / "server" / "ipc" / "records.py"}
EXCLUDED_DIRS = {ROOT / "server" / "bench"}
TAGS = {cls.TAG for channel in CHANNELS for cls in channel.records}
RECORD_NAMES = {"record", "rec"}


def _sources():
    for top in ("server", "devices"):
        for path in sorted((ROOT / top).rglob("*.py")):
            if path in EXCLUDED or any(d in path.parents for d in EXCLUDED_DIRS):
                continue
            yield path


def _int_index(node: ast.Subscript) -> bool:
    return isinstance(node.slice, ast.Constant) and isinstance(node.slice.value, int)


def _tag(node) -> bool:
    return isinstance(node, ast.Constant) and node.value in TAGS


def positional(tree: ast.AST) -> list[int]:
    """The lines of `tree` that read, build or dispatch a record by position."""
    lines = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Subscript) and isinstance(node.value, ast.Name) and node.value.id in RECORD_NAMES \
                and _int_index(node):
            lines.append(node.lineno)
        elif isinstance(node, ast.List) and node.elts and _tag(node.elts[0]) and not (
                len(node.elts) > 1 and all(isinstance(e, ast.Constant) and isinstance(e.value, str) for e in node.elts)):
            lines.append(node.lineno)
        elif isinstance(node, ast.Compare) and isinstance(node.left, ast.Subscript) and _int_index(node.left) \
                and node.left.slice.value == 0 and any(_tag(c) for c in node.comparators):
            lines.append(node.lineno)
    return sorted(lines)


def test_no_record_is_read_built_or_dispatched_by_position_outside_its_declaration():
    found = []
    for path in _sources():
        text = path.read_text(encoding="utf-8")
        lines = text.splitlines()
        found += [f"{path.relative_to(ROOT)}:{n}: {lines[n - 1].strip()}" for n in positional(ast.parse(text))]
    assert found == [], "positional records (declare and use server/ipc/records.py instead):\n" + "\n".join(found)


def test_the_scan_sees_what_it_looks_for():
    code = ('self.sim.release(record[1])\nself.outbox.append(["log", "error", text])\nout.append(["stop"])\n'
            'if r[0] == "state": pass\n'
            'table(["answer", "n", "share"])\nx = row[0]\ny = t["scenario"]\nz = ["tracker_udp", 1]\n')
    assert sorted(positional(ast.parse(code))) == [1, 2, 3, 4]
    assert len(list(_sources())) > 100
