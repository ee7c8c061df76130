#!/usr/bin/env python3
"""Writes the missing Unity `.meta` files of this package (a git package is read-only to Unity,
which ignores assets without one). The GUID is derived from the path, so running it twice, or on
two machines, writes the same files. Folders ending in `~` or starting with `.` are not assets."""

from __future__ import annotations

import hashlib
from pathlib import Path

HERE = Path(__file__).resolve().parent
IMPORTERS = {".cs": "MonoImporter", ".asmdef": "AssemblyDefinitionImporter", ".md": "TextScriptImporter",
             ".json": "TextScriptImporter"}


def is_asset(path: Path) -> bool:
    rel = path.relative_to(HERE)
    return not any(p.startswith(".") or p.endswith("~") for p in rel.parts) and path.suffix != ".meta"


def meta_text(path: Path) -> str:
    guid = hashlib.md5(("viestac-unity:" + path.relative_to(HERE).as_posix()).encode()).hexdigest()
    if path.is_dir():
        return f"fileFormatVersion: 2\nguid: {guid}\nfolderAsset: yes\nDefaultImporter:\n  externalObjects: {{}}\n  userData: \n"
    importer = "PackageManifestImporter" if path == HERE / "package.json" else IMPORTERS.get(path.suffix, "DefaultImporter")
    return f"fileFormatVersion: 2\nguid: {guid}\n{importer}:\n  externalObjects: {{}}\n  userData: \n"


def main() -> None:
    written = 0
    for path in sorted(HERE.rglob("*")):
        if not is_asset(path):
            continue
        meta = path.with_name(path.name + ".meta")
        if not meta.exists():
            meta.write_text(meta_text(path))
            written += 1
    print(f"wrote {written} .meta files")


if __name__ == "__main__":
    main()
