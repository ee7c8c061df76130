import pytest

from tests.report.battery_data import battery_data


@pytest.fixture(scope="session")
def battery(request):
    """model → data directory of the small simulated batteries (kept in pytest's cache)."""
    return battery_data(request.config.cache.mkdir("report-card-battery"))
