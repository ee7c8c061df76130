import pytest


@pytest.fixture(scope="session")
def battery(report_card_battery):
    """model → data directory of the small simulated batteries (tests/conftest.py)."""
    return report_card_battery
