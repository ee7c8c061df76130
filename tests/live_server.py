"""The tests' live-server harness: real `viestac serve` processes (hub, 1 kHz loop, simulated rig)
on ephemeral ports, each with an admin token of its own that `get_json` sends by default.

Starting and stopping a server is server/launcher.py's (`viestac bench` runs servers the same
way); what only the tests use lives here: the LiveServer handle of the conftest fixtures.
Tests import the harness from here, never from server.bench (only tests/bench tests the bench).
"""

from __future__ import annotations

from dataclasses import dataclass

from server.launcher import UNLIMITED_OVERRUNS, admin_token, auth_headers, get_json, start_server, stop_server

__all__ = ["UNLIMITED_OVERRUNS", "LiveServer", "admin_token", "auth_headers", "get_json", "serve", "start_server",
           "stop_server"]


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


def serve(scenario: str = "contact-angle"):
    """A fixture's body: a LiveServer for the fixture's scope, stopped afterwards."""
    proc, base = start_server(scenario)
    try:
        yield LiveServer(base, base.replace("http://", "ws://") + "/ws")
    finally:
        stop_server(proc)
