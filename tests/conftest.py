"""Shared fixtures: a real server process (hub + 1 kHz loop) on an ephemeral port."""

from __future__ import annotations

import os
import tempfile

import pytest

from tests.live_server import serve


@pytest.fixture(scope="session", autouse=True)
def temporary_files_under_pytest(tmp_path_factory):
    """Every temporary file and directory the suite and the processes it starts make (a server's
    simulated rig, a bench's scratch, a browser profile) goes under pytest's own temporary
    directory, which pytest prunes to its last runs: a test that dies before its cleanup leaves
    nothing in /tmp for ever."""
    path = tmp_path_factory.mktemp("tmp")
    before = os.environ.get("TMPDIR")
    os.environ["TMPDIR"] = str(path)
    tempfile.tempdir = None  # gettempdir() reads TMPDIR again
    yield path
    if before is None:
        os.environ.pop("TMPDIR", None)
    else:
        os.environ["TMPDIR"] = before
    tempfile.tempdir = None


@pytest.fixture(scope="session")
def live_server():
    """The shared server: tests must leave it as they found it (its scenario, its processes)."""
    yield from serve()


@pytest.fixture(scope="module")
def own_server():
    """A server of the test module's own, for tests that kill, stall or flood it."""
    yield from serve()


@pytest.fixture(scope="session")
def report_card_battery(tmp_path_factory):
    """model → data directory of the report card's small simulated batteries (tests/report,
    tests/browser/test_report_card.py), simulated once per test run: never reused from an earlier
    run, so the data always come from the code under test."""
    from tests.report.battery_data import battery_data

    return battery_data(tmp_path_factory.mktemp("report-card-battery"))
