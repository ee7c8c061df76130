"""`viestac report devices DATA --out DIR`: the battery studies in DATA (`battery-<model>`), each
analysed as `viestac analyze` does (server/analysis/run.compute), turned into the card
(card.py), written as DIR/stats.json and DIR/report-card.html (self-contained: figures inline
as SVG, no network). Deterministic: the same data give the same files.
"""

from __future__ import annotations

import json
from pathlib import Path

from devices.manager import DeviceConfigError, load_device_file
from devices.profiles import ProfileError
from server import __version__
from server.analysis.load import AnalysisError, database_file, load
from server.analysis.run import compute
from server.battery.parts import plan_for
from server.experiment.export import ExportError, Reader
from server.report import card, figures, page

STUDY_PREFIX = "battery-"
PAGE, STATS = "report-card.html", "stats.json"


def battery_studies(data: str | Path) -> dict[str, str]:
    """model → study id of every battery study in DATA."""
    path = database_file(data)
    try:
        with Reader(path) as reader:
            ids = sorted({s["study_id"] for s in reader.sessions()})
    except ExportError as exc:
        raise AnalysisError(str(exc)) from None
    found = {i.removeprefix(STUDY_PREFIX): i for i in ids if i.startswith(STUDY_PREFIX)}
    if not found:
        raise AnalysisError(f"{path} holds no battery study (an id `{STUDY_PREFIX}<model>`); "
                            f"its studies: {', '.join(ids) or 'none'}")
    return found


def calibration_from_rig(rig: str | Path | None):
    """(channel, calibration) of the first calibrated audio channel of a rig file, else None."""
    if rig is None:
        return None
    try:
        configs = load_device_file(rig)
    except (DeviceConfigError, OSError) as exc:
        raise AnalysisError(f"--rig {rig}: {exc}") from None
    for c in configs:
        for ch in (c.audio.channels if c.audio else ()):
            if ch.calibration is not None:
                return ch, ch.calibration
    raise AnalysisError(f"--rig {rig}: no audio channel with a calibration")


def build(data: str | Path | list, rig: str | Path | None = None) -> tuple[dict, list[dict]]:
    """stats.json's content and the figures ({name, title, svg, sources}) of the battery studies
    in DATA (one data directory or .sqlite file, or several: a lab may keep one per device)."""
    calibration = calibration_from_rig(rig)
    found: dict[str, tuple[str, Path]] = {}
    for path in [data] if isinstance(data, (str, Path)) else list(data):
        for model, study in battery_studies(path).items():
            if model in found:
                raise AnalysisError(f"study {study} is in both {found[model][1]} and {database_file(path)}: "
                                    f"give each device's battery once")
            found[model] = (study, database_file(path))
    cards, studies = [], []
    for model, (study, data) in sorted(found.items()):
        try:
            plans = plan_for(model)
        except ProfileError as exc:
            raise AnalysisError(f"study {study}: {exc}") from None
        dataset = load(data, study)
        analysis, frames = compute(dataset)
        cards.append(card.device_card(model, plans, analysis, frames["task4_kept"],
                                      calibration if model == "audio" else None))
        prov = analysis["provenance"]
        studies.append({"study_id": study, "model": model, "database": str(data), "n_sessions": prov["n_sessions"],
                        "n_participants": prov["n_participants"], "study_hashes": prov["study_hashes"],
                        "warnings": prov["warnings"]})
    provenance = {"databases": sorted({str(p) for _, p in found.values()}), "viestac": __version__, "studies": studies,
                  "calibration_rig": None if rig is None else str(rig)}
    stats = card.card_stats(cards, provenance)
    drawn = figures.all_figures(stats)
    stats["figures"] = [{"name": f["name"], "title": f["title"], "sources": f["sources"]} for f in drawn]
    return stats, drawn


def report_devices(data: str | Path | list, out: str | Path, rig: str | Path | None = None) -> dict:
    """Write OUT/stats.json and OUT/report-card.html; return the stats."""
    stats, drawn = build(data, rig)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / STATS).write_text(json.dumps(stats, indent=2, ensure_ascii=False, allow_nan=False) + "\n", encoding="utf-8")
    (out / PAGE).write_text(page.render(stats, drawn), encoding="utf-8")
    return stats
