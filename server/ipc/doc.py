"""The tables of the records between the processes in docs/architecture.md "The mailbox", from
their declarations (server/ipc/records.py).

    python -m server.ipc.doc           # rewrite them
    python -m server.ipc.doc --check   # exit 1 if they are stale (tests/ipc/test_doc.py too)

Each table sits between `<!-- generated: records CHANNEL -->` and `<!-- end generated -->` (the
channel's name as declared, e.g. `hub → loop`); the text around it is written by hand.
"""

from __future__ import annotations

import re
import sys
from dataclasses import fields
from pathlib import Path

from server.ipc.records import CHANNELS, Channel, Record

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "architecture.md"
_BLOCK = re.compile(r"(<!-- generated: (?P<key>[^>]+?) -->\n)(?P<body>.*?)(<!-- end generated -->)", re.S)


def _one_line(text: str) -> str:
    return " ".join(text.split()).replace("|", "\\|")


def _array(cls: type[Record]) -> str:
    if cls.SHAPE is not None:
        return f"`{cls.SHAPE}`"
    names = list(cls.FIELDS)
    if cls.TAIL:
        names[-cls.TAIL:] = [f"({', '.join(names[-cls.TAIL:])})"]
    return "`[" + ", ".join([f'"{cls.TAG}"', *names]) + "]`"


def _fields(cls: type[Record]) -> str:
    return "; ".join(f"`{f.name}`: {_one_line(f.metadata.get('doc', ''))}" for f in fields(cls))


def channel_table(channel: Channel) -> str:
    rows = [f"{_one_line(channel.doc).capitalize()}.", "",
            "| record | on the socket | meaning | fields |", "|---|---|---|---|"]
    for cls in channel.records:
        rows.append(f"| `{cls.__name__}` | {_array(cls)} | {_one_line(cls.__doc__ or '')} | {_fields(cls)} |")
    return "\n".join(rows) + "\n"


TABLES = {f"records {channel.name}": (lambda channel=channel: channel_table(channel)) for channel in CHANNELS}


def render_doc(text: str) -> str:
    """`text` with every generated records table rewritten (other generated blocks stay)."""
    def block(m: re.Match) -> str:
        render = TABLES.get(m.group("key"))
        return m.group(0) if render is None else m.group(1) + render() + m.group(4)
    return _BLOCK.sub(block, text)


def doc_blocks(text: str) -> dict[str, str]:
    """The generated records tables of `text` as written: key -> body."""
    return {m.group("key"): m.group("body") for m in _BLOCK.finditer(text) if m.group("key").startswith("records ")}


def main(argv: list[str]) -> int:
    text = DOC.read_text(encoding="utf-8")
    missing = set(TABLES) - set(doc_blocks(text))
    if missing:
        print(f"{DOC}: no generated block for {', '.join(sorted(missing))}", file=sys.stderr)
        return 1
    rendered = render_doc(text)
    if "--check" in argv:
        if rendered != text:
            print(f"{DOC} is stale: run python -m server.ipc.doc", file=sys.stderr)
            return 1
        return 0
    if rendered != text:
        DOC.write_text(rendered, encoding="utf-8")
        print(f"wrote {DOC}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
