"""`viestac analyze` on a database of psychophysics sessions written with the Store (records from
the synthetic observer answering the real procedures): stats.json has the psychophysics section,
report.html shows each of its figures and the very numbers of stats.json, the thesis tasks still
report (skipped, no data), and the output is deterministic."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from html import unescape
from pathlib import Path

import numpy as np
import pytest

from server.analysis.report import fmt, interval
from server.psychophysics.observer import PsychometricObserver
from tests.analysis import psychophysics_rows as pr

ROOT = Path(__file__).resolve().parents[2]
STAIRCASE = {"kind": "up-down", "start": 40, "steps": [8, 4, 2], "up": 1, "down": 2, "max_reversals": 10,
             "average": 6, "min": 0.5, "max": 100}
CONSTANT = {"kind": "constant", "levels": [5, 10, 15, 20, 25], "repeats": 8}


def analyze(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "server.cli", "analyze", *args], capture_output=True, text=True,
                          timeout=300, cwd=ROOT)


def build(path: Path) -> None:
    rng = np.random.default_rng(36)
    two = PsychometricObserver(15.0, 0.3, 0.5, 0.0, "logistic")
    yes = PsychometricObserver(15.0, 0.3, 0.0, 0.02, "logistic")
    data = {f"P{i + 1:02d}": {
        "detect": pr.records("2ifc", two, STAIRCASE, rng, condition="f250")
        + pr.records("2ifc", PsychometricObserver(10.0, 0.3, 0.5, 0.0), STAIRCASE, rng, condition="f100"),
        "yes_no": pr.records("yes-no", yes, CONSTANT, rng, noise_rate=0.25),
        "identify": pr.identification([100, 200, 300, 400], 0.7, 6, rng)} for i in range(3)}
    pr.write_database(path, data)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    base = tmp_path_factory.mktemp("psy")
    build(base / "data" / "viestac.sqlite")
    result = analyze(str(base / "data"), "--out", str(base / "out"), "--workers", "1")
    assert result.returncode == 0, result.stderr
    return {"base": base, "out": base / "out", "stats": json.loads((base / "out" / "stats.json").read_text()),
            "html": (base / "out" / "report.html").read_text(encoding="utf-8")}


def test_stats_hold_every_task_and_the_thesis_tasks_still_run(run):
    stats = run["stats"]
    psy = stats["psychophysics"]
    assert [t["task"] for t in psy["tasks"]] == ["detect", "identify", "yes_no"]
    assert psy["n_participants"] == 3 and psy["bootstrap_samples"] > 0
    assert [c["condition"] for c in psy["tasks"][0]["conditions"]] == ["f100", "f250"]
    assert "psychophysics" in stats["methods"]
    assert not [k for k in stats["skipped"] if k.startswith("psychophysics.")], stats["skipped"]
    # the thesis's analyses ran and said why they have nothing
    assert stats["task1"]["n_trials"] == 0 and "task1.per_angle" in stats["skipped"]


def figure_names(out: Path) -> set[str]:
    return {p.stem for p in (out / "figures").glob("psy_*.svg")}


def test_report_shows_each_figure(run):
    names = figure_names(run["out"])
    # tracks only for an adaptive procedure (the constant stimuli of yes_no have none)
    assert names == {"psy_detect_curves", "psy_detect_tracks", "psy_yes_no_curves", "psy_identify_main_confusion"}
    for name in names:
        assert f'<figure id="fig-{name}">' in run["html"], name
        assert (run["out"] / "figures" / f"{name}.png").stat().st_size > 0


def rows_of(html: str, task: str) -> list[list[str]]:
    """The body rows of every table in a task's part of the report, cell texts unescaped."""
    part = html.split(f'<h3 id="psy_{task}">', 1)[1].split("<h3", 1)[0]
    return [[unescape(re.sub(r"<[^>]+>", "", c)) for c in re.findall(r"<td[^>]*>(.*?)</td>", row)]
            for row in re.findall(r"<tr>(.*?)</tr>", part) if "<td" in row]


def test_report_numbers_are_the_stats_numbers(run):
    psy, html = run["stats"]["psychophysics"], run["html"]
    for task in psy["tasks"]:
        rows = rows_of(html, task["task"])
        for cond in task["conditions"]:
            for cell in [cond["pooled"], *cond["participants"]]:
                who = cell["participant"] or "pooled"
                shown = [r for r in rows if r[:2] == [cond["condition"], who]]
                if task["design"] != "identification":
                    f, b = cell["fit"], cell["bootstrap"]
                    assert [f["family"], fmt(f["threshold"]), interval(b["threshold_ci95"]), fmt(f["slope"]),
                            interval(b["slope_ci95"]), fmt(f["lapse"]), fmt(f["midpoint"]),
                            interval(b["midpoint_ci95"]), fmt(f["deviance"]), fmt(b["deviance_p"]),
                            fmt(cell["procedure_estimate"])] == shown[0][3:], (task["task"], who)
                if task["design"] == "yes-no":
                    s = cell["sdt"]
                    assert [fmt(s["d_prime"]), fmt(s["criterion"])] == shown[1][-2:]
                    assert [str(s["hits"]), str(s["signal_trials"])] == shown[1][3:5]
                if task["design"] == "identification":
                    i = cell["information"]
                    assert [str(i["trials"]), fmt(i["accuracy"]), fmt(i["bits"]), fmt(i["corrected"]),
                            fmt(i["maximum"])] == shown[0][2:]


def test_same_database_same_files(run):
    again = analyze(str(run["base"] / "data"), "--out", str(run["base"] / "again"), "--workers", "2")
    assert again.returncode == 0, again.stderr
    for name in ("stats.json", "report.html"):
        assert (run["base"] / "again" / name).read_bytes() == (run["out"] / name).read_bytes(), name
    for f in (run["out"] / "figures").glob("psy_*"):
        assert (run["base"] / "again" / "figures" / f.name).read_bytes() == f.read_bytes(), f.name
