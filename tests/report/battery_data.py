"""Small simulated battery data for the report card's tests: battery study files made from the
parts catalogue (server/battery/parts.py: each part's own task table) with fewer trials and a
subset of the parts, run with `viestac study --simulate` (synthetic participants, seeded)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from server.battery.parts import ANGLES_DEG, plan_for

ROOT = Path(__file__).resolve().parents[2]


def _toml(value) -> str:
    """A TOML value (inline tables for nested tables: a study file is read with tomllib)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float, str)):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return "{ " + ", ".join(f"{json.dumps(str(k))} = {_toml(v)}" for k, v in dict(value).items()) + " }"


def _only_carriers(task: dict, carriers: tuple[str, ...] | None) -> dict:
    """The task with its interleaved detection conditions cut to `carriers` (all where none match)."""
    task = json.loads(json.dumps(task, default=dict))
    psy = task.get("psychophysics")
    if psy is None or psy["procedure"]["kind"] != "interleaved" or carriers is None:
        return task
    proc = psy["procedure"]
    keep = [c for c in proc["conditions"] if c in carriers] or list(proc["conditions"])
    per = psy["max_trials"] // len(proc["conditions"])
    proc["conditions"] = {c: proc["conditions"][c] for c in keep}
    if psy.get("conditions"):
        psy["conditions"] = {c: psy["conditions"][c] for c in keep}
    psy["max_trials"] = per * len(keep)
    return task


def battery_file(model: str, parts: tuple[str, ...], trials: int | None, participants: int, directory: Path,
                 carriers: tuple[str, ...] | None = None) -> Path:
    """battery-<model>.toml with `parts` (part ids of plan_for(model) that run), `trials` main trials
    each (an identification part's rounded down to whole repeats; None: the catalogue's own counts)."""
    lines = [f'id = "battery-{model}"', f'title = "Battery (test) {model}"', "seed = 38",
             f"participants = {participants}", ""]
    counts = {} if trials is None else {
        p: trials - trials % len(ANGLES_DEG) if p == "angle_identification" else trials
        for p in parts if p != "positioning"}
    for plan in plan_for(model, counts):
        if plan.part.id not in parts or not plan.runs:
            continue
        task = _only_carriers(dict(plan.task), carriers)
        lines += ["[[tasks]]", f'id = "{plan.part.id}"', f"title = {_toml(plan.part.title)}",
                  f'scenario = "{"positioning" if plan.part.id == "positioning" else "stimulus"}"',
                  f'device = "{model}"']
        lines += [f"{k} = {_toml(v)}" for k, v in task.items()]
        lines.append("")
    path = directory / f"battery-{model}.toml"
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


def simulate(study: Path, out: Path, participants: int, seed: int = 38) -> Path:
    """`viestac study --simulate` (no analysis); returns the data directory."""
    subprocess.run([sys.executable, "-m", "server.cli", "study", "--study", str(study), "--simulate", "--participants",
                    str(participants), "--seed", str(seed), "--out", str(out), "--no-analysis", "--quiet",
                    "--workers", "1"], check=True, cwd=ROOT)
    return out / "data"


PARTICIPANTS = 5   # the paired tests' minimum (server/report/card.MIN_PAIRS)
TRIALS = 24
DEVICES = {  # model → the parts simulated (the rest of its plan: "no data" or skipped)
    "audio": ("detection", "amplitude_jnd", "frequency_jnd", "positioning"),
    "ferrovibe": ("detection", "amplitude_jnd", "angle_identification"),
}
CARRIERS = ("f80", "f250")


def battery_data(directory: Path) -> dict[str, Path]:
    """model → data directory of its simulated battery in `directory` (seeded: the same file gives
    the same data; a directory that already holds a model's run for the same file reuses it)."""
    import hashlib

    out = {}
    for model, parts in DEVICES.items():
        studies = directory / "studies"
        studies.mkdir(parents=True, exist_ok=True)
        study = battery_file(model, parts, TRIALS, PARTICIPANTS, studies, CARRIERS)
        key = hashlib.sha256(study.read_bytes()).hexdigest()[:16]
        run = directory / f"{model}-{key}"
        if not (run / "data" / "viestac.sqlite").exists():
            simulate(study, run, PARTICIPANTS)
        out[model] = run / "data"
    return out
