"""One thread owns the hub (docs/architecture.md "The hub"): every record the REST API sends to
the loop leaves from the event loop's thread. The mailbox doorbell's ring is an unlocked
read-modify-write of a shared counter, so a ring from a worker thread racing one from the event
loop can lose a wake-up; here every ring is recorded with its thread, in the real app (loop
process, device host, simulated rig) driven through its REST API."""

from __future__ import annotations

import json
import threading
import time
import urllib.error
import urllib.request

import uvicorn

from server import ipc
from server.app import create_app
from server.config import Settings


ADMIN = "owner-thread-test-admin-token-0123456789"  # VIESTAC_ADMIN_TOKEN of the in-process server


class Rest:
    def __init__(self, base: str):
        self.base = base

    def __call__(self, method: str, path: str, body: dict | None = None, headers: dict | None = None,
                 expect: tuple = (200, 201)):
        request = urllib.request.Request(self.base + path, method=method, headers={
            "Content-Type": "application/json", "Authorization": f"Bearer {ADMIN}", **(headers or {})},
            data=None if body is None else json.dumps(body).encode())
        try:
            with urllib.request.urlopen(request, timeout=10) as response:
                status, answer = response.status, json.loads(response.read())
        except urllib.error.HTTPError as exc:
            status, answer = exc.code, json.loads(exc.read())
        assert status in expect, (method, path, status, answer)
        return answer


def test_every_rest_request_rings_the_loop_from_the_event_loop_thread(tmp_path, monkeypatch):
    rings: list[int] = []
    ring = ipc.Doorbell.ring

    def recording_ring(self):
        rings.append(threading.get_ident())
        ring(self)

    monkeypatch.setattr(ipc.Doorbell, "ring", recording_ring)
    monkeypatch.setenv("VIESTAC_ADMIN_TOKEN", ADMIN)
    app = create_app(Settings(data_dir=tmp_path / "data", tracker_udp="off"))
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=0, log_level="warning"))
    serving = threading.Thread(target=server.run, name="event-loop")  # the app's event loop runs here
    serving.start()
    try:
        deadline = time.monotonic() + 20
        while not server.started:
            assert serving.is_alive() and time.monotonic() < deadline, "the server did not start"
            time.sleep(0.05)
        rest = Rest("http://127.0.0.1:%d" % server.servers[0].sockets[0].getsockname()[1])
        while rest("GET", "/api/scenario", expect=(200, 503)).get("id") is None:
            assert time.monotonic() < deadline, "the loop did not announce its scenario"
            time.sleep(0.05)
        rest("POST", "/api/lease")  # the rig's changes need the control lease
        rings.clear()

        rest("POST", "/api/scenario", {"name": "stiffness", "params": {"middle_level": 3}, "seed": 1})
        rest("POST", "/api/trial", {"phase": "main", "params": {"mode": "production", "level": 7, "start_level": 2},
                                    "index": 1})
        rest("POST", "/api/command", {"key": "x", "action": "press"})
        rest("DELETE", "/api/trial")
        by_rest = len(rings)
        assert by_rest == 4

        session = rest("POST", "/api/sessions", {"study": "thesis-2021", "participant": "T01", "experimenter": "alice"})
        headers = {"X-Control-Token": session["token"]}
        sid = session["id"]
        for trial in session["trials"][:2]:  # a training (free exploration), then a trial with a question
            rest("POST", f"/api/sessions/{sid}/trials/{trial['seq']}/start", headers=headers)
            for question in trial["questions"]:
                rest("PUT", f"/api/sessions/{sid}/trials/{trial['seq']}/responses/{question}", {"value": 10.0},
                     headers=headers)
            finished = rest("POST", f"/api/sessions/{sid}/trials/{trial['seq']}/finish", headers=headers)
            assert finished["status"] == "answered"
        assert len(rings) >= by_rest + 2 * 4  # each start and finish sends the recording switch and the trial
    finally:
        server.should_exit = True
        serving.join(30)

    others = sum(t != serving.ident for t in rings)
    assert others == 0, f"{others} of {len(rings)} rings came from a thread other than the event loop's"
