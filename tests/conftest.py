"""Shared fixtures: a real server process (hub + 1 kHz loop) on an ephemeral port."""

from __future__ import annotations

import json
import urllib.request
from dataclasses import dataclass

import pytest

from server.bench.loop_bench import start_server, stop_server


@dataclass
class LiveServer:
    http_url: str
    ws_url: str

    def get(self, path: str):
        with urllib.request.urlopen(self.http_url + path, timeout=5) as response:
            return json.loads(response.read())

    def post(self, path: str):
        request = urllib.request.Request(self.http_url + path, method="POST")
        with urllib.request.urlopen(request, timeout=5) as response:
            return json.loads(response.read())


@pytest.fixture(scope="session")
def live_server():
    proc, base = start_server("contact-angle")
    try:
        yield LiveServer(base, base.replace("http://", "ws://") + "/ws")
    finally:
        stop_server(proc)
