import pytest

from scenarios import registry
from tests.experiment import stimulus_standin


@pytest.fixture
def stimulus(monkeypatch):
    """The stimulus scenario (Contract C1): the real one, or the stand-in while main has none."""
    monkeypatch.setattr(registry, "SCENARIOS", stimulus_standin.registered())
    return registry.resolve("stimulus")
