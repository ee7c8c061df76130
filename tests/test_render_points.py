"""`viestac render` of a multi-point trajectory (several fingers, a hand): the format export
writes (server/core/records.py), each tool's own columns, and the single-point format unchanged."""

import csv
import subprocess
import sys

import pytest

from server.core.points import PRIMARY_POINT
from server.core.records import multipoint_columns
from server.render import TrajectoryError, make_simulation, read_trajectory, render

THUMB = "right.thumb.tip"


def write(path, header, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)


def press(n=61):
    """The thumb presses down onto the dome top over 0.5 s while the index stays aside; the wrist
    is tracked for the first half only (empty cells after)."""
    rows = []
    for i in range(n):
        wrist = (0.1, 0.0, 1.5) if i < n // 2 else ("", "", "")
        rows.append((i / 120, *wrist, 0.0, 0.0, 1.0 - 0.8 * i / 60, 0.0, 0.5, 1.2))
    return rows


HEADER = multipoint_columns(["right.wrist", THUMB, PRIMARY_POINT])


def test_a_multipoint_file_reads_as_points_per_sample(tmp_path):
    path = tmp_path / "hand.csv"
    write(path, HEADER, press())
    samples = read_trajectory(path)
    assert samples[0] == (0.0, {"right.wrist": (0.1, 0.0, 1.5), THUMB: (0.0, 0.0, 1.0), PRIMARY_POINT: (0.0, 0.5, 1.2)})
    assert set(samples[-1][1]) == {THUMB, PRIMARY_POINT}, "an empty cell: not tracked in that sample"


def test_the_thumb_touches_in_its_own_columns_and_the_index_does_not(tmp_path):
    path, out = tmp_path / "hand.csv", tmp_path / "out.csv"
    write(path, HEADER, press())
    ticks = render(make_simulation("contact-angle", tools=(THUMB,)), read_trajectory(path), out)
    with open(out) as f:
        table = list(csv.DictReader(f))
    assert len(table) == ticks == 501
    assert list(table[0])[-5:] == [f"{THUMB}.{c}" for c in ("proxy_x", "proxy_y", "proxy_z", "contact", "cues")]
    assert any(r[f"{THUMB}.contact"] == "1" for r in table) and all(r["contact"] == "0" for r in table)
    assert all(r["cues"] == "[]" for r in table), "contact-angle cues the primary tool only"
    for r in table:
        assert float(r[f"{THUMB}.proxy_z"]) >= 0.6 + 0.06 - 1e-9, "the thumb's proxy stays outside the dome"


def test_without_tool_the_thumb_is_a_drawn_point_only(tmp_path):
    path, out = tmp_path / "hand.csv", tmp_path / "out.csv"
    write(path, HEADER, press())
    render(make_simulation("contact-angle"), read_trajectory(path), out)
    with open(out) as f:
        header = next(csv.reader(f))
    assert not any(c.startswith(THUMB) for c in header)


def test_a_sample_without_the_primary_point_drives_the_tool_it_names(tmp_path):
    path, out = tmp_path / "thumb.csv", tmp_path / "out.csv"
    write(path, multipoint_columns([THUMB]), [(i / 100, 0.0, 0.0, 1.0 - 0.8 * i / 50) for i in range(51)])
    sim = make_simulation("contact-angle", tools=(THUMB,))
    render(sim, read_trajectory(path), out)
    assert sim.data.tool_by_name[THUMB].driver == "render" and sim.data.tools[0].driver is None


@pytest.mark.parametrize("header, row, message", [
    (["t", "right.thumb.tip.x", "right.thumb.tip.y"], [0, 0, 0], "need all of .x, .y and .z"),
    (["t", "thumb.x", "thumb.y", "thumb.z"], [0, 0, 0, 0], "not a tracked point name"),
    (["t", "right.thumb.tip.w", "right.thumb.tip.y", "right.thumb.tip.z"], [0, 0, 0, 0], "is not NAME.x"),
    (["t", "right.thumb.tip.x", "right.thumb.tip.y", "right.thumb.tip.z"], [0, "a", 0, 0], "must be numbers"),
    (["t", "right.thumb.tip.x", "right.thumb.tip.y", "right.thumb.tip.z"], [0, "", "", ""], "no point"),
])
def test_bad_multipoint_files_are_refused_with_the_line(tmp_path, header, row, message):
    path = tmp_path / "bad.csv"
    write(path, header, [row])
    with pytest.raises(TrajectoryError, match=message):
        read_trajectory(path)


def test_the_command_line_takes_tools(tmp_path):
    path, out = tmp_path / "hand.csv", tmp_path / "out.csv"
    write(path, HEADER, press())
    result = subprocess.run([sys.executable, "-m", "server.cli", "render", "--scene", "contact-angle", "--trajectory",
                             str(path), "--out", str(out), "--tool", THUMB], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    with open(out) as f:
        assert f"{THUMB}.contact" in next(csv.reader(f))
