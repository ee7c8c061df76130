"""`viestac report devices`: the card's numbers are server/analysis/psychophysics.py's for the same
data, the page's numbers are stats.json's, every part of every device's plan is there (skipped
ones with the capability check's reason), paired tests and physical units are right, and bad
input gets a clear error."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from html import escape
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from scipy import stats as sps

from devices.manager import load_device_file
from server.analysis.load import AnalysisError, load
from server.analysis.report import fmt
from server.analysis.run import compute
from server.battery.parts import BY_ID, plan_for
from server.psychophysics import literature
from server.report import card
from server.report.run import PAGE, STATS, report_devices
from tests.report.battery_data import DEVICES, ROOT

RIG = """
[[device]]
name = "coil"
profile = "audio"
[device.audio]
output = "system"
host_api = "JACK"
[[device.audio.channel]]
actuator = "coil"
channel = 1
gain = 1.0
peak = 0.9
frequency_hz = [20, 1000]
calibration = { unit = "m/s^2", points = [[20, 1.0, 4.0], [250, 0.5, 9.5], [250, 1.0, 19.0], [1000, 1.0, 6.0]] }
"""


@pytest.fixture(scope="module")
def report(battery, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("card")
    rig = out / "rig.toml"
    rig.write_text(RIG, encoding="utf-8")
    subprocess.run([sys.executable, "-m", "server.cli", "report", "devices", *map(str, battery.values()),
                    "--out", str(out / "card"), "--rig", str(rig)], check=True, cwd=ROOT)
    return out


def stats_of(report: Path) -> dict:
    return json.loads((report / "card" / STATS).read_text(encoding="utf-8"))


def at(stats: dict, path: str):
    value = stats
    for key in path.split("."):
        value = value[int(key)] if isinstance(value, list) else value[key]
    return value


def test_every_part_of_every_plan_is_listed_with_its_status(report):
    stats = stats_of(report)
    assert [c["model"] for c in stats["devices"]] == sorted(DEVICES)
    for c in stats["devices"]:
        plans = plan_for(c["model"])
        assert [p["part"] for p in c["parts"]] == [p.part.id for p in plans]
        for row, plan in zip(c["parts"], plans):
            if not plan.runs:
                assert row["status"] == "skipped" and row["reason"] == plan.reason and row["reason"]
            elif plan.part.id in DEVICES[c["model"]]:
                assert row["status"] == "measured" and row["measures"], row
            else:
                assert row["status"] == "no data" and row["measures"] == []
    audio = next(c for c in stats["devices"] if c["model"] == "audio")
    tilt = next(p for p in audio["parts"] if p["part"] == "tilt_direction")
    assert tilt["reason"].startswith("device audio cannot show a tilt cue")


def test_numbers_equal_the_psychophysics_analysis_of_the_same_data(report, battery):
    stats = stats_of(report)
    for c in stats["devices"]:
        analysis, _ = compute(load(battery[c["model"]], f"battery-{c['model']}"))
        tasks = {t["task"]: t for t in analysis["psychophysics"]["tasks"]}
        for part in c["parts"]:
            for m in part["measures"]:
                if part["part"] == "positioning":
                    d = analysis["task4"][c["model"]][m["measure"]]
                    assert (m["value"], m["ci95"], m["n_participants"]) == \
                        (d["mean"], [d["ci95_low"], d["ci95_high"]], d["n_participants"])
                    continue
                cond = next(x for x in tasks[part["part"]]["conditions"] if x["condition"] == m["condition"])
                assert m["n_participants"] == cond["n_participants"] and m["n_trials"] == cond["n_trials"]
                if m["measure"] == "it_bits":
                    bits = [x["information"]["corrected"] for x in cond["participants"]]
                    assert m["value"] == pytest.approx(np.mean(bits), rel=1e-12)
                    assert m["pooled"] == cond["pooled"]["information"]["corrected"]
                    continue
                alpha, ci = cond["pooled"]["fit"]["threshold"], cond["pooled"]["bootstrap"]["threshold_ci95"]
                ref = BY_ID[part["part"]].reference
                expect = {"threshold": lambda a, r=ref: a, "jnd": lambda a, r=ref: a - r,  # comparisons above r
                          "amplitude_jnd_db": lambda a, r=ref: 20 * math.log10(a / r),
                          "frequency_weber": lambda a, r=ref: (a - r) / r}[m["measure"]]
                assert m["alpha"] == alpha
                assert m["value"] == pytest.approx(expect(alpha), rel=1e-12)
                assert m["ci95"] == pytest.approx(sorted([expect(ci[0]), expect(ci[1])]), rel=1e-12)
                per = {x["participant"]: expect(x["fit"]["threshold"]) for x in cond["participants"] if x["fit"]}
                assert m["per_participant"] == pytest.approx(per, rel=1e-12)


def test_detection_is_per_carrier_and_physical_units_follow_the_calibration(report):
    stats = stats_of(report)
    channel = load_device_file(report / "rig.toml")[0].audio.channels[0]
    audio = next(c for c in stats["devices"] if c["model"] == "audio")
    detection = next(p for p in audio["parts"] if p["part"] == "detection")["measures"]
    assert sorted(m["carrier_hz"] for m in detection) == [80.0, 250.0]
    for m in detection:
        expect = channel.calibration.peak_for(m["carrier_hz"], channel.drive(m["value"]))
        assert m["physical"]["unit"] == "m/s^2" and m["physical"]["value"] == pytest.approx(expect)
    ferro = next(c for c in stats["devices"] if c["model"] == "ferrovibe")
    fixed = next(p for p in ferro["parts"] if p["part"] == "detection")["measures"]
    assert [m["carrier_hz"] for m in fixed] == [235.0] and fixed[0]["physical"] is None  # no calibration


def test_paired_tests_are_scipy_on_the_participants_who_wore_both(report):
    stats = stats_of(report)
    paired = stats["comparison"]["paired"]
    assert {(t["part"], t["measure"]) for t in paired} == {("amplitude_jnd", "jnd"),
                                                           ("amplitude_jnd", "amplitude_jnd_db")}
    by = {c["model"]: c for c in stats["devices"]}
    for t in paired:
        a, b = (next(m for p in by[d]["parts"] if p["part"] == t["part"] for m in p["measures"]
                     if m["measure"] == t["measure"])["per_participant"] for d in t["devices"])
        common = sorted(set(a) & set(b))
        assert t["n_pairs"] == len(common) == 5
        xa, xb = [a[k] for k in common], [b[k] for k in common]
        assert t["wilcoxon"]["p"] == pytest.approx(sps.wilcoxon(xa, xb).pvalue)
        assert t["t_test"]["p"] == pytest.approx(sps.ttest_rel(xa, xb).pvalue)
    # detection: the audio's carriers and the FerroVibe's own are different conditions, no pair
    assert all(t["part"] != "detection" for t in paired)


class _Stats(HTMLParser):
    def __init__(self):
        super().__init__()
        self.found, self._open, self.figures = [], None, []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if "data-stat" in a:
            self._open = [a["data-stat"], json.loads(a["data-value"]), ""]
        if tag == "figure":
            self.figures.append(a["id"])

    def handle_data(self, data):
        if self._open is not None:
            self._open[2] += data

    def handle_endtag(self, tag):
        if tag == "span" and self._open is not None:
            self.found.append(tuple(self._open))
            self._open = None


def test_the_page_prints_stats_json_and_every_figure_with_its_sources(report):
    stats = stats_of(report)
    html = (report / "card" / PAGE).read_text(encoding="utf-8")
    parser = _Stats()
    parser.feed(html)
    assert len(parser.found) > 40
    for path, value, text in parser.found:
        assert at(stats, path) == value, path
        assert text == fmt(value), path
    values = {p for p, _, _ in parser.found}
    for i, c in enumerate(stats["devices"]):  # every measured number is on the page
        for j, p in enumerate(c["parts"]):
            for k, _ in enumerate(p["measures"]):
                assert f"devices.{i}.parts.{j}.measures.{k}.value" in values
                assert f"devices.{i}.parts.{j}.measures.{k}.ci95.0" in values
    assert parser.figures == [f"fig-{f['name']}" for f in stats["figures"]]
    assert [f["name"] for f in stats["figures"]] == ["detection", "discrimination", "information", "positioning"]
    for source in literature.SOURCES.values():
        assert escape(source.citation) in html
    for c in stats["devices"]:
        for p in c["parts"]:
            if p["status"] == "skipped":
                assert escape(p["reason"]) in html
    assert "http://" not in html and "https://" not in html and "<script" not in html


def test_report_is_deterministic(report, battery, tmp_path):
    rig = report / "rig.toml"
    report_devices(list(battery.values()), tmp_path, rig=rig)
    assert (tmp_path / PAGE).read_bytes() == (report / "card" / PAGE).read_bytes()


def test_data_without_a_battery_study_is_refused_clearly(tmp_path):
    thesis_like = tmp_path / "x"
    thesis_like.mkdir()
    run = subprocess.run([sys.executable, "-m", "server.cli", "report", "devices", str(thesis_like), "--out",
                          str(tmp_path / "out")], capture_output=True, text=True, cwd=ROOT)
    assert run.returncode == 2 and "viestac report devices:" in run.stderr and "Traceback" not in run.stderr


def test_the_same_device_twice_is_refused(battery, tmp_path):
    with pytest.raises(AnalysisError, match="give each device's battery once"):
        report_devices([battery["audio"], battery["audio"] / "viestac.sqlite"], tmp_path)


def test_literature_bands_are_the_issues_numbers():
    assert (literature.BANDS["amplitude_jnd_db"].low, literature.BANDS["amplitude_jnd_db"].high) == (1.65, 2.98)
    assert (literature.BANDS["frequency_weber"].low, literature.BANDS["frequency_weber"].high) == (0.13, 0.38)
    assert (literature.BANDS["stiffness_weber"].low, literature.BANDS["stiffness_weber"].high) == (0.15, 0.22)
    shape = {e.frequency_hz: e.middle_db for e in literature.DETECTION_BAND_DB}
    assert min(shape, key=shape.get) == 250


def test_the_detection_band_is_drawn_from_the_declared_edges(report):
    from server.report import figures

    stats = stats_of(report)
    band = stats["literature"]["detection"]
    declared = literature.DETECTION_BAND_DB
    assert band["frequency_hz"] == [e.frequency_hz for e in declared]
    assert band["low_db"] == [e.low_db for e in declared] and band["high_db"] == [e.high_db for e in declared]
    assert all(lo < hi for lo, hi in zip(band["low_db"], band["high_db"]))
    fig = figures.detection(stats)
    shape = fig.axes[1]  # right: dB re each device's lowest threshold, with the band
    (filled,) = [c for c in shape.collections if c.get_label().startswith("literature")]
    outline = {tuple(np.round(v, 6)) for p in filled.get_paths() for v in p.vertices}
    for e in declared:
        assert (e.frequency_hz, e.low_db) in outline and (e.frequency_hz, e.high_db) in outline


def test_a_jnd_below_the_reference_counts_positive():
    from dataclasses import replace

    assert all(card.direction(p) == 1 for m in ("audio", "fingertac") for p in plan_for(m) if p.task)
    stiffness = next(p for p in plan_for("fingertac") if p.part.id == "stiffness")
    procedure = {**stiffness.task["psychophysics"]["procedure"], "min": 0.2, "max": 0.495}
    softer = replace(stiffness, task={**stiffness.task, "psychophysics": {**stiffness.task["psychophysics"],
                                                                          "procedure": procedure}})
    assert card.direction(softer) == -1
    (key, _, jnd), (_, _, weber) = card._transform("stiffness", -1)
    assert (jnd(0.4), weber(0.4)) == pytest.approx((0.1, 0.2))


def test_a_part_with_no_analysed_trials_is_no_data_not_missing():
    plans = plan_for("devkit")
    empty = {"psychophysics": {"tasks": []}, "task4": {}, "provenance": {"n_participants": 0, "sessions": []}}
    import pandas as pd

    c = card.device_card("devkit", plans, empty, pd.DataFrame())
    assert [p["status"] for p in c["parts"]] == ["skipped" if not p.runs else "no data" for p in plans]


def test_a_singular_sphericity_test_is_a_skip_not_a_crash():
    """Two participants, three levels: pingouin's Mauchly test divides by zero; `viestac analyze`
    (which the card runs per battery) must skip the ANOVA with a reason rather than stop."""
    import pandas as pd

    from server.analysis.stats import Skip, rm_anova

    frame = pd.DataFrame({"participant": ["a"] * 3 + ["b"] * 3, "object": [1, 2, 3] * 2,
                          "x": [1.0, 2.0, 4.0, 2.0, 3.0, 3.5]})
    with pytest.raises(Skip, match="sphericity"):
        rm_anova(frame, "x", "object")


def test_a_threshold_beyond_the_tested_levels_is_flagged_and_kept_out_of_the_figures():
    import pandas as pd

    from server.report import figures, page

    def condition(name, alpha):
        cell = {"points": [{"level": 10.0}, {"level": 100.0}], "fit": {"threshold": alpha},
                "bootstrap": {"threshold_ci95": [alpha * 0.8, alpha * 1.2]}, "participant": None}
        return {"condition": name, "n_trials": 40, "n_participants": 1, "pooled": cell,
                "participants": [{**cell, "participant": "P1"}]}

    analysis = {"psychophysics": {"tasks": [{"task": "detection", "unit": "%", "conditions": [
        condition("f40", 187077.0), condition("f250", 20.0)]}]}, "task4": {},
        "provenance": {"n_participants": 1, "sessions": [{"participant": "P1"}]}}
    c = card.device_card("audio", plan_for("audio"), analysis, pd.DataFrame())
    measures = {m["condition"]: m for m in c["parts"][0]["measures"]}
    assert measures["f40"]["within_tested_range"] is False and measures["f40"]["tested_range"] == [10.0, 100.0]
    assert measures["f250"]["within_tested_range"] is True
    stats = card.card_stats([c], {"studies": []})
    drawn = figures.all_figures(stats)
    assert [m["condition"] for _, _, m in figures.detection_rows(stats)] == ["f250"]
    assert "detection" in [f["name"] for f in drawn]
    html = page.render(stats, drawn)
    assert html.count("(beyond the tested levels)") == 1
