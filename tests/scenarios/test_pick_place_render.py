"""A recorded two-finger pick-and-place replays through `viestac render` (the multi-point CSV a
session records): the grasp, the placement and each finger's own cue column come back."""

import csv
import json

from server.core.records import multipoint_columns
from server.render import make_simulation, read_trajectory, render
from scenarios.pick_place import BLOCK, BLOCK_SIDE, BLOCK_START, INDEX, THUMB
from tests.scenarios.driving import line

HALF = BLOCK_SIDE / 2
TOUCH = HALF + 0.06
HZ = 120  # a tracker's rate, as the Leap Motion's


def pinch(centre, gap):
    x, y, z = centre
    return (x, y + TOUCH + gap, z), (x, y - TOUCH - gap, z)


def recording() -> list[tuple]:
    """Fingers close on the block (0.5 s), hold (0.25 s), carry it to the target (1 s), open."""
    start, over = (*BLOCK_START, HALF), (0.0, -0.9, HALF + 0.02)
    closing = [pinch(start, 0.1 - 0.13 * k / 60) for k in range(61)]
    holding = [pinch(start, -0.03)] * 30
    carrying = [pinch(c, -0.03) for c in line(start, over, 120)]
    opening = [pinch(over, -0.03 + 0.13 * k / 30) for k in range(1, 31)]
    frames = closing + holding + carrying + opening
    return [(k / HZ, *index, *thumb) for k, (index, thumb) in enumerate(frames)]


def test_a_recorded_grasp_and_place_replays_through_render(tmp_path):
    path, out = tmp_path / "pick.csv", tmp_path / "out.csv"
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(multipoint_columns([INDEX, THUMB]))
        w.writerows(recording())
    sim = make_simulation("pick-place")
    ticks = render(sim, read_trajectory(path), out)
    with open(out) as f:
        table = list(csv.DictReader(f))
    assert len(table) == ticks
    values = [json.loads(r["values"]) for r in table]
    phases = [v["phase"] for v in values]
    assert [p for k, p in enumerate(phases) if k == 0 or p != phases[k - 1]] == ["idle", "held", "placed"]
    assert values[-1]["drops"] == 0 and values[-1]["placement_error"] < 0.02
    assert sim.data.moved[BLOCK].pos[2] == HALF and abs(sim.data.moved[BLOCK].pos[1] + 0.9) < 0.02
    thumb_cued = [r[f"{THUMB}.cues"] != "[]" for r in table]
    index_cued = [r["cues"] != "[]" for r in table]
    assert any(thumb_cued) and any(index_cued), "each finger's contact cue in its own column"
    assert not thumb_cued[-1] and not index_cued[-1], "no cue once the fingers let go"
