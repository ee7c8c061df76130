"""Practice trials are exported as `kind = practice` (issue 34 point 9): the plan calls them `trial`
(the thesis's phase name), which in an exported file reads as if they were the trials themselves."""

from __future__ import annotations

import json

from server.experiment.export import export
from server.experiment.store import Store
from tests.experiment.test_export import clock, item, new_session, read_csv


def test_practice_trials_are_exported_as_practice(tmp_path):
    store = Store(tmp_path / "data" / "viestac.sqlite", clock())
    try:
        ids = new_session(store, "s1", "P01", [item(0, "training", 0), item(1, "trial", 0, {"angle_deg": 10.0},
                                                                            ["answer_deg"], 0),
                                               item(2, "main", 0, {"angle_deg": 20.0}, ["answer_deg"], 0)])
        for seq in (1, 2):
            store.transition(ids[seq], "running", tick=1000 * seq)
            store.put_response(ids[seq], "answer_deg", 10 * seq, "alice")
            store.transition(ids[seq], "answered", tick=1000 * seq + 500)
        [summary] = export(store.path, tmp_path / "out", "s1")
    finally:
        store.close()
    folder = tmp_path / "out" / "demo_P01_s1"
    assert [r["kind"] for r in read_csv(folder / "trials_wide.csv")] == ["training", "practice", "main"]
    assert [r["kind"] for r in read_csv(folder / "responses_long.csv")] == ["practice", "main"]
    session = json.loads((folder / "session.json").read_text(encoding="utf-8"))
    assert [t["kind"] for t in session["trials"]] == ["training", "practice", "main"]
    assert summary["trials"] == 3
