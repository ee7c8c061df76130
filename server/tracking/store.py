"""Calibrations on disk: one JSON file per source name in DATA_DIR/trackers/, loaded at start.

A source without a file starts with its kind's default (the Leap: millimetres and axes →
scene, server/tracking/calibration.py; replays and scripts: identity, they are in scene units).
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

from server.tracking.calibration import Calibration
from server.tracking.sources import KINDS

_NAME = re.compile(r"^[a-z][a-z0-9_-]{0,31}$")


def default_for(kind: str) -> Calibration:
    declared = KINDS.get(kind)
    return declared.calibration() if declared is not None else Calibration()


def path_for(data_dir: Path, name: str) -> Path:
    if not _NAME.match(name):
        raise ValueError(f"bad tracker source name {name!r}")
    return Path(data_dir) / "trackers" / f"{name}.calibration.json"


def load(data_dir: Path, name: str, kind: str) -> Calibration:
    path = path_for(data_dir, name)
    if not path.is_file():
        return default_for(kind)
    return Calibration.from_dict(json.loads(path.read_text()))


def save(data_dir: Path, name: str, calibration: Calibration) -> Path:
    path = path_for(data_dir, name)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(calibration.to_dict(), indent=1))
    os.replace(tmp, path)  # never a half-written calibration
    return path


def remove(data_dir: Path, name: str) -> None:
    path_for(data_dir, name).unlink(missing_ok=True)
