"""Shared fixtures: a real server process (hub + 1 kHz loop) on an ephemeral port."""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass

import pytest

from server.bench.loop_bench import get_json, start_server, stop_server


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


@dataclass
class LiveServer:
    http_url: str
    ws_url: str

    def get(self, path: str):
        return get_json(self.http_url + path)

    def post(self, path: str, body: dict | None = None):
        return get_json(self.http_url + path, "POST", body=body)

    def delete(self, path: str):
        return get_json(self.http_url + path, "DELETE")


def _serve():
    proc, base = start_server("contact-angle")
    try:
        yield LiveServer(base, base.replace("http://", "ws://") + "/ws")
    finally:
        stop_server(proc)


@pytest.fixture(scope="session")
def live_server():
    """The shared server: tests must leave it as they found it (its scenario, its processes)."""
    yield from _serve()


@pytest.fixture(scope="module")
def own_server():
    """A server of the test module's own, for tests that kill, stall or flood it."""
    yield from _serve()
