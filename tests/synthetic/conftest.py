"""Shared helpers for the synthetic-participant tests: the thesis study and its questions."""

from __future__ import annotations

from pathlib import Path

import pytest

from server.experiment.study import load_study

ROOT = Path(__file__).resolve().parents[2]
THESIS = ROOT / "studies" / "thesis-2021.toml"
PERIODS_US = (2000.0, 3000.0, 4000.0, 5000.0, 6000.0)


@pytest.fixture(scope="session")
def thesis():
    return load_study(THESIS)


@pytest.fixture(scope="session")
def questions(thesis):
    """The thesis study's questions by id (the task answers and the questionnaire items)."""
    return {q.id: q for task in thesis.tasks for q in task.questions + task.end_questions}
