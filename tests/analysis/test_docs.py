"""docs/analysis.md documents every stats.json key of server/analysis/keys.py."""

from pathlib import Path

from server.analysis.keys import KEYS, REQUIRED

DOC = Path(__file__).resolve().parents[2] / "docs" / "analysis.md"


def test_every_stats_key_is_documented():
    doc = DOC.read_text(encoding="utf-8")
    assert [k for k in KEYS if f"`{k}`" not in doc] == []
    assert [k for k in REQUIRED if f"`{k}`" not in doc] == []
