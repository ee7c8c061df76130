import pytest

from scenarios import registry


@pytest.fixture
def stimulus():
    """The stimulus scenario (Contract C1 of the psychophysics tasks: scenarios/stimulus.py)."""
    return registry.resolve("stimulus")
