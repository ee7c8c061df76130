"""docs/architecture.md "The mailbox" shows the records as declared (server/ipc/doc.py)."""

from server.ipc import doc
from server.ipc.records import CHANNELS


def test_the_mailbox_tables_are_current():
    written = doc.doc_blocks(doc.DOC.read_text(encoding="utf-8"))
    assert set(written) == {f"records {c.name}" for c in CHANNELS}, "docs/architecture.md lacks or has extra tables"
    for key, render in doc.TABLES.items():
        assert written[key] == render(), f"docs/architecture.md '{key}' differs: run python -m server.ipc.doc"


def test_a_stale_table_is_rewritten_and_the_rest_of_the_text_kept():
    text = doc.DOC.read_text(encoding="utf-8")
    assert doc.render_doc(text) == text
    edited = text.replace("| `TrackerGone` |", "| `TrackerLeft` |", 1)
    assert edited != text and doc.render_doc(edited) == text


def test_every_record_and_field_is_in_its_table():
    for channel in CHANNELS:
        table = doc.channel_table(channel)
        for cls in channel.records:
            assert f"`{cls.__name__}`" in table and f'"{cls.TAG}"' in table
            assert all(f"`{name}`:" in table for name in cls.FIELDS), cls.__name__
