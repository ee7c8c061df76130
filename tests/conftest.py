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


@pytest.fixture(scope="session")
def live_server():
    proc, base = start_server("contact-angle")
    try:
        yield LiveServer(base, base.replace("http://", "ws://") + "/ws")
    finally:
        stop_server(proc)
