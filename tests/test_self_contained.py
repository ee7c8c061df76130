"""The repository explains itself: no file cites reading material that is not in it, and every
pointer into docs/ names a file and a section that exist.

The design notes and the restated specification the project started from were never part of
the repository; what the code needs from them is in docs/reference.md, with the primary
sources. A comment that cites them leaves a maintainer with nothing to open.
"""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# Assembled from pieces so that this file's own source does not match.
_NOTES = ("rendering", "ecosystem", "clients-trackers")
OUTSIDE_DOCUMENTS = re.compile("|".join([
    "spec" + r"\.md",
    *(name + "-" + "notes" for name in _NOTES),
    "loop" + "-probe",
    "shared" + "/",
    "reference" + " notes",
]), re.IGNORECASE)

# docs/<name>.md followed by a quoted section title (optionally after a comma).
SECTION_POINTER = re.compile(r'\bdocs/([A-Za-z0-9_-]+\.md),? "([^"\n]+)"')
FILE_POINTER = re.compile(r"\bdocs/([A-Za-z0-9_-]+\.md)\b")
HEADING_NUMBER = re.compile(r"^\d+(\.\d+)*\.?\s+")

# Only for a tree without git (a container built from a copy): what .gitignore leaves out.
_UNTRACKED_DIRS = {".git", ".venv", "node_modules", "__pycache__", ".pytest_cache", ".hypothesis", "build",
                   "out", "data", "artifacts"}


def tracked_files() -> list[Path]:
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
        names = [n for n in out.decode().split("\0") if n]
    except (OSError, subprocess.CalledProcessError):
        names = []
        for folder, dirs, files in os.walk(ROOT):
            dirs[:] = [d for d in dirs if d not in _UNTRACKED_DIRS and not d.endswith(".egg-info")]
            names += [os.path.relpath(os.path.join(folder, f), ROOT) for f in files]
    assert names, "found no files to check"
    return [ROOT / n for n in names if (ROOT / n).is_file()]


def text_lines(path: Path) -> list[str] | None:
    data = path.read_bytes()
    if b"\0" in data:  # images, compiled files
        return None
    return data.decode("utf-8", errors="replace").splitlines()


def headings(path: Path) -> list[str]:
    """Each Markdown heading's text, without the #s and a leading section number ("5. Link budget")."""
    return [HEADING_NUMBER.sub("", line.lstrip("#").strip()).lower()
            for line in path.read_text(encoding="utf-8").splitlines() if line.startswith("#")]


def test_no_file_cites_documents_outside_the_repository():
    offenders = []
    for path in tracked_files():
        for number, line in enumerate(text_lines(path) or (), 1):
            match = OUTSIDE_DOCUMENTS.search(line)
            if match:
                offenders.append(f"{path.relative_to(ROOT)}:{number}: {match.group(0)!r} in {line.strip()[:100]!r}")
    assert not offenders, ("these lines cite documents that are not in the repository; point to docs/ "
                           "(docs/reference.md) or to a primary source instead:\n" + "\n".join(offenders))


def test_pointers_into_docs_name_existing_files_and_sections():
    docs = ROOT / "docs"
    sections = {p.name: headings(p) for p in docs.glob("*.md")}
    assert "reference.md" in sections, "docs/reference.md holds what the code takes from outside sources"
    broken = []
    for path in tracked_files():
        for number, line in enumerate(text_lines(path) or (), 1):
            where = f"{path.relative_to(ROOT)}:{number}"
            for name in FILE_POINTER.findall(line):
                if name not in sections:
                    broken.append(f"{where}: docs/{name} does not exist")
            for name, section in SECTION_POINTER.findall(line):
                if name in sections and not any(h.startswith(section.lower()) for h in sections[name]):
                    broken.append(f'{where}: docs/{name} has no section "{section}"')
    assert not broken, "pointers into docs/ that lead nowhere:\n" + "\n".join(broken)
