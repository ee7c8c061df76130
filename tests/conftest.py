"""Shared fixtures: a real server process (hub + 1 kHz loop) on an ephemeral port."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from server.bench.loop_bench import get_json, start_server, stop_server


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
