"""The cue rows a store holds for one trial, read straight from its database (the product reads
them per session, in server/experiment/export.py)."""

import json


def cue_rows(store, trial_id: int) -> list[dict]:
    rows = store.db.execute("SELECT * FROM cues WHERE trial_id = ? ORDER BY attempt, tick", (trial_id,))
    return [{"attempt": r["attempt"], "tick": r["tick"], "cues": json.loads(r["cues_json"])} for r in rows]
