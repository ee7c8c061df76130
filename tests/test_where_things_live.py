"""docs/architecture.md "Where things live" names every Python module under server/, devices/ and
scenarios/, under its directory: a new module without its line there fails here."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TREES = ("server", "devices", "scenarios")
_ENTRY = re.compile(r"^( {0,2})(\S+)")


def where_things_live() -> dict[str, str]:
    """The section's entries: a path ("server/hub/", "server/app.py", "devices/") → its text."""
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    section = text.split("## Where things live", 1)[1].split("\n## ", 1)[0]
    block = section.split("```", 2)[1]
    entries: dict[str, str] = {}
    top, key = "", None
    for line in block.splitlines():
        m = _ENTRY.match(line)
        if m and ("/" in m.group(2) or m.group(2).endswith(".py")):
            path = m.group(2) if not m.group(1) else top + m.group(2)
            if not m.group(1):
                top = path
            key = path
            entries[key] = line[len(m.group(0)):]
        elif key is not None:
            entries[key] += " " + line
    return entries


def unnamed(entries: dict[str, str]) -> list[str]:
    missing = []
    for tree in TREES:
        for path in sorted((ROOT / tree).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            if path.name == "__init__.py" or "/firmware/" in rel or rel in entries:
                continue
            folders = [k for k in entries if k.endswith("/") and rel.startswith(k)]
            nearest = max(folders, key=len, default=None)
            if nearest is None or not re.search(rf"\b{re.escape(path.stem)}\b", entries[nearest]):
                missing.append(f"{rel} (under {nearest or 'no entry'})")
    return missing


def test_every_module_is_named_under_its_directory():
    missing = unnamed(where_things_live())
    assert not missing, "not in docs/architecture.md \"Where things live\": " + ", ".join(missing)


def test_the_entries_are_read_as_written():
    entries = where_things_live()
    assert "server/hub/" in entries and "tracker_health" in entries["server/hub/"]
    assert "server/app.py" in entries and "devices/" in entries and "scenarios/" in entries
    without = {k: v.replace("event_log", "") for k, v in entries.items()}
    assert unnamed(without) == ["server/hub/event_log.py (under server/hub/)"]
