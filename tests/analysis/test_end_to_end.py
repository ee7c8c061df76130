"""`python -m server.cli analyze` on a database of 13 synthetic thesis-study sessions written with the
Store: stats.json holds every required key with the values the generating models and independent
computations give, report.html is valid, self-contained and shows every figure, and the output
is deterministic."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from server.analysis.keys import KEYS, REQUIRED, lookup, why_missing
from server.experiment.store import Store
from tests.analysis.test_reference import kendall_by_counting
from tests.analysis.thesis_data import Truth, build, clock

ROOT = Path(__file__).resolve().parents[2]


def analyze(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "server.cli", "analyze", *args], capture_output=True, text=True,
                          timeout=180, cwd=ROOT)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    base = tmp_path_factory.mktemp("analysis")
    drawn = build(base / "data" / "viestac.sqlite", Truth())
    result = analyze(str(base / "data"), "--out", str(base / "out"))
    assert result.returncode == 0, result.stderr
    stats = json.loads((base / "out" / "stats.json").read_text(encoding="utf-8"))
    return {"base": base, "out": base / "out", "stats": stats, "drawn": drawn, "stdout": result.stdout}


def test_every_required_and_documented_key(run):
    stats = run["stats"]
    for path in REQUIRED:
        assert why_missing(stats, path) is None, path
    assert stats["skipped"] == {}, stats["skipped"]
    for key in KEYS:
        if "<" in key or "[]" in key or key.startswith("rm_anova."):
            continue
        lookup(stats, key)
    assert "analysed 13 sessions (13 participants) of study thesis-2021" in run["stdout"]


def test_task1_counts_main_trials_only_and_drops_the_excluded_one(run):
    t1, prov = run["stats"]["task1"], run["stats"]["provenance"]
    assert t1["n_trials"] == 13 * 10 - 1 == len(run["drawn"]["angles"])
    assert [(e["participant"], e["task"], e["reason"]) for e in prov["excluded_trials"]] == \
        [("P02", "contact_angle", "participant sneezed")]
    assert t1["rm_anova"]["n_participants"] == 12 and t1["rm_anova"]["n_dropped_incomplete"] == 1
    devs = [abs(a - ang) for _, ang, a in run["drawn"]["angles"]]
    assert t1["mean_abs_dev"]["mean"] == pytest.approx(np.mean(devs))   # practice answers (−angle) not counted
    assert 0 < t1["rm_anova"]["eps"] <= 1 and 0 <= t1["rm_anova"]["p_gg"] <= 1


def test_task2_kendall_and_ratings(run):
    t2, drawn = run["stats"]["task2"], run["drawn"]
    tau, p = kendall_by_counting([a for _, a, _ in drawn["ident"]], [d for _, _, d in drawn["ident"]])
    assert t2["kendall_tau"] == pytest.approx(tau, rel=1e-12) and t2["kendall_tau_p"] == pytest.approx(p, rel=1e-9)
    assert 0.5 < t2["kendall_tau"] < 1.0
    means = {r["comparison"]: r["mean"] for r in t2["pairs"]["per_comparison"]}
    assert means["166.67 vs 250 Hz"] > means["250 vs 250 Hz"] > means["500 vs 250 Hz"]
    assert t2["pairs"]["reference"] == "250 vs 250 Hz" and t2["pairs"]["rm_anova"]["p_gg"] < 0.001
    assert {r["comparison"] for r in t2["pairs"]["posthoc"]["tests"]} == set(means) - {"250 vs 250 Hz"}


@pytest.mark.parametrize("mode", ["estimation", "production"])
def test_task3_power_laws(run, mode):
    part = run["stats"]["task3"][mode]
    rows = np.array([(s, v) for _, s, v in run["drawn"][mode] if 2 <= s <= 9], dtype=float)
    slope, intercept = np.polyfit(np.log(rows[:, 0]), np.log(rows[:, 1]), 1)
    assert part["b"] == pytest.approx(slope, rel=1e-9) and part["a"] == pytest.approx(math.exp(intercept), rel=1e-9)
    a, b = getattr(Truth(), mode)
    assert part["b"] == pytest.approx(b, abs=0.05) and part["fit"]["levels"] == list(range(2, 10))


def test_task4_outlier_device_means_and_throughput(run):
    t4 = run["stats"]["task4"]
    assert t4["outliers"]["n_excluded"] == 1
    assert {(o["participant"], o["cue"], o["object"]) for o in t4["outliers"]["trials"]} == {("P03", "P3", "cube_b")}
    kept = [r for r in run["drawn"]["positioning"] if not (r[0] == "P03" and r[2] == "P3" and r[3] == "cube_b")]
    for device, cues in (("fingertac", {"P1", "P2", "P3"}), ("ferrovibe", {"3dof"})):
        rows = [r for r in kept if r[1] == device and r[2] in cues]
        assert t4[device]["trajectory_length"]["mean"] == pytest.approx(np.mean([r[4] for r in rows]))
        assert t4[device]["completion_time"]["mean"] == pytest.approx(np.mean([r[5] for r in rows]))
        assert t4[device]["completion_time"]["sd"] == pytest.approx(np.std([r[5] for r in rows], ddof=1))
    assert t4["fingertac"]["rm_anova"]["trajectory_length"]["within"] == ["cue", "object"]
    assert t4["ferrovibe"]["rm_anova"]["completion_time"]["within"] == ["object"]
    comparison = t4["comparison"]["fingertac_vs_ferrovibe"]["completion_time"]
    assert comparison["n_pairs"] == 13 and comparison["mean_diff"] < 0 and comparison["p"] < 0.05
    assert set(t4["throughput"]["by_device"]) == {"fingertac", "ferrovibe"}
    assert all(c["TP"] > 0 for c in t4["throughput"]["conditions"])
    assert set(t4["questionnaire"]) == {"better_mode", "better_by", "best_pattern"}
    assert sum(c["n"] for c in t4["questionnaire"]["best_pattern"]["counts"]) == 13


class Checker(HTMLParser):
    """Tags must nest and close (void elements excepted); collects img sources and external refs."""
    VOID = {"meta", "img", "br", "hr", "link", "input", "col", "source"}

    def __init__(self):
        super().__init__()
        self.stack, self.errors, self.images, self.external = [], [], [], []

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag in ("script", "link", "iframe"):
            self.external.append(tag)
        for key in ("src", "href"):
            if attrs.get(key) and not attrs[key].startswith(("data:", "#")):
                self.external.append(attrs[key])
        if tag == "img":
            self.images.append(attrs)
        if tag not in self.VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag):
        if not self.stack or self.stack.pop() != tag:
            self.errors.append(f"unexpected </{tag}>")


def test_report_is_valid_self_contained_html_with_every_figure(run):
    html = (run["out"] / "report.html").read_text(encoding="utf-8")
    assert html.startswith("<!DOCTYPE html>")
    checker = Checker()
    checker.feed(html)
    assert checker.errors == [] and checker.stack == [] and checker.external == []
    figures = sorted(p.stem for p in (run["out"] / "figures").glob("*.png"))
    assert figures == sorted(p.stem for p in (run["out"] / "figures").glob("*.svg"))
    assert len(figures) == 10   # task 1: 1, task 2: 2, task 3: 2, task 4: both devices, helpfulness, devices, speed
    assert sorted(re.findall(r'<figure id="fig-([\w-]+)">', html)) == figures
    assert len(checker.images) == len(figures) and all(i["src"].startswith("data:image/svg+xml;base64,")
                                                        for i in checker.images)
    for word in ("Greenhouse-Geisser", "tau-b", "log-log OLS", "far out", "Excluded trials", "participant sneezed",
                 "ISO 9241-411", run["stats"]["provenance"]["study_hashes"][0][:16]):
        assert word in html, word


@pytest.mark.parametrize("workers", ["1", "3"])
def test_output_is_deterministic(run, tmp_path, workers):
    """Again, with the figures drawn here (1) or in three forked processes: the same bytes."""
    result = analyze(str(run["base"] / "data"), "--out", str(tmp_path), "--workers", workers)
    assert result.returncode == 0, result.stderr
    for path in sorted(run["out"].rglob("*")):
        if path.is_file():
            assert path.read_bytes() == (tmp_path / path.relative_to(run["out"])).read_bytes(), path.name
    svg = (run["out"] / "figures" / "task1_angles.svg").read_text()
    assert "<dc:date>" not in svg


def test_cli_errors_exit_2(tmp_path):
    missing = analyze(str(tmp_path / "nowhere"), "--out", str(tmp_path / "o"))
    assert missing.returncode == 2 and "no database" in missing.stderr
    no_workers = analyze(str(tmp_path), "--out", str(tmp_path / "o"), "--workers", "0")
    assert no_workers.returncode == 2 and "--workers must be at least 1" in no_workers.stderr
    store = Store(tmp_path / "viestac.sqlite", clock())
    for sid, study in (("a1", "demo"), ("b1", "other")):
        store.create_session(session_id=sid, study_id=study, study_title=study.title(), study_hash="h",
                             study_text="", participant="P01", participant_index=0, device=None, experimenter="x",
                             notes="", software_version="0.1.0", config={}, plan=[])
    store.close()
    both = analyze(str(tmp_path / "viestac.sqlite"), "--out", str(tmp_path / "o"))
    assert both.returncode == 2 and "several studies (demo, other)" in both.stderr
    unknown = analyze(str(tmp_path), "--study", "nope", "--out", str(tmp_path / "o"))
    assert unknown.returncode == 2 and "no sessions of study 'nope'" in unknown.stderr
    empty = analyze(str(tmp_path), "--study", "demo", "--out", str(tmp_path / "o"))
    assert empty.returncode == 0, empty.stderr
    stats = json.loads((tmp_path / "o" / "stats.json").read_text())
    assert all(why_missing(stats, p) not in (None, "missing") for p in REQUIRED)
    assert "skipped task1.rm_anova" in empty.stdout and (tmp_path / "o" / "report.html").is_file()


def test_an_unwritable_out_exits_2(run, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    result = analyze(str(run["base"] / "data"), "--out", str(blocker))
    assert result.returncode == 2 and "cannot write" in result.stderr
