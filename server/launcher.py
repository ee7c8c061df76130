"""Run `viestac serve` as a child process tree and act as its admin: how `viestac bench` and the
tests run the real server (tests/live_server.py is the tests' side of it).

Each server start_server starts gets an admin token of its own (env VIESTAC_ADMIN_TOKEN: held in
the server's memory only), takes the control lease with it, and registers it in ADMIN_TOKENS, so
`get_json` on that server's URLs sends it and WebSocket clients find it with `admin_token(url)`.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import urllib.parse

import psutil

from server.auth.tokens import new_secret
from server.client import request_json


ADMIN_TOKENS: dict[str, str] = {}  # base URL (scheme://host:port) of a server start_server made → its admin token
_REGISTERED = object()  # get_json's default: the token registered for the URL's server, if any


def _base(url: str) -> str:
    """scheme://host:port of a URL; ws(s):// maps to the http(s) base of the same server."""
    parts = urllib.parse.urlsplit(url)
    scheme = {"ws": "http", "wss": "https"}.get(parts.scheme, parts.scheme)
    return f"{scheme}://{parts.netloc}"


def admin_token(url: str) -> str | None:
    """The admin token start_server registered for the server at `url` (http(s):// or ws(s)://)."""
    return ADMIN_TOKENS.get(_base(url))


def auth_headers(url: str, token=_REGISTERED) -> dict[str, str]:
    """The Authorization header for a request to `url`: `token`, or the registered one by default
    (`token=None`: none)."""
    if token is _REGISTERED:
        token = admin_token(url)
    return {"Authorization": f"Bearer {token}"} if token else {}


ANSWER_TIMEOUT_S = 30.0  # a bound for a hung server, not a speed check: a loaded machine answers late


def get_json(url: str, method: str = "GET", timeout: float = ANSWER_TIMEOUT_S, body: dict | None = None,
             token=_REGISTERED) -> dict:
    """GET (or POST, DELETE with an optional JSON body) a URL of the server and decode its JSON
    answer; HTTP errors raise urllib.error.HTTPError (its .code and .read() carry the detail).
    Sends `token` as the bearer token; by default the one start_server registered for that
    server (`token=None`: no token)."""
    if token is _REGISTERED:
        token = admin_token(url)
    return request_json(url, method, token=token, body=body, timeout=timeout)


UNLIMITED_OVERRUNS = 10_000  # the largest threshold: every tick of a 10 s window late


LEASE_TTL_S = 86400  # the harness's lease lasts the run (a test that studies expiry passes --lease-ttl)


def start_server(scenario: str = "contact-angle", extra: list[str] | None = None,
                 timeout_s: float = 30.0, *, take_lease: bool = True,
                 python: str = sys.executable) -> tuple[subprocess.Popen, str]:
    """Start `viestac serve --port 0` (in `python`: this one, or another venv's); return the
    process and its base URL once healthy, with an admin token registered for it (ADMIN_TOKENS)
    that holds the control lease (unless not `take_lease`)."""
    extra = list(extra or [])
    if "--lease-ttl" not in extra:
        extra += ["--lease-ttl", str(LEASE_TTL_S)]
    if "--overrun-threshold" not in extra:
        # Test and bench servers share a loaded machine and measure timing themselves; health
        # would otherwise say `degraded` for overruns and they would wait for `ok` in vain.
        extra += ["--overrun-threshold", str(UNLIMITED_OVERRUNS)]
    own_data = "--data-dir" not in extra
    if own_data:  # a server of its own gets a database of its own, removed when it stops
        extra += ["--data-dir", tempfile.mkdtemp(prefix="viestac-data-")]
    secret = new_secret(32)
    proc = subprocess.Popen([python, "-m", "server.cli", "serve", "--port", "0", "--scenario", scenario,
                             "--log-level", "warning", *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env={**os.environ, "VIESTAC_ADMIN_TOKEN": secret})
    proc.own_data_dir = extra[extra.index("--data-dir") + 1] if own_data else None
    deadline = time.monotonic() + timeout_s
    base = None
    assert proc.stdout is not None
    while base is None:
        line = proc.stdout.readline()
        if not line:
            raise RuntimeError(f"server exited early with code {proc.wait()}")
        match = re.search(r"on (https?://\S+?)/ ", line)
        if match:
            base = match.group(1)
            ADMIN_TOKENS[base] = secret
            proc.base_url = base
        if time.monotonic() > deadline:
            proc.kill()
            raise RuntimeError("server did not print its URL in time")
    # Keep draining the server's output so it never blocks on a full pipe.
    threading.Thread(target=lambda: [None for _ in proc.stdout], daemon=True).start()
    health: dict | str = "no answer"
    while True:
        try:
            health = get_json(base + "/api/health")
            if health["status"] == "ok":
                if take_lease:
                    take_the_lease(base)
                return proc, base
        except OSError as exc:
            health = f"no answer: {exc}"
        if time.monotonic() > deadline:
            reasons = health.get("reasons") if isinstance(health, dict) else health
            devices = _devices_now(base, proc.pid)  # a device that never connected: what its link and emulator did
            proc.kill()
            raise RuntimeError(f"server did not become healthy in time; health says {reasons!r:.600}; "
                               f"devices: {devices:.3000}")
        time.sleep(0.1)


def _devices_now(base: str, hub: int) -> str:
    """Each device's status, link counters, last error and last events, and the rig's emulators."""
    try:
        answer = get_json(base + "/api/devices", timeout=2.0)
    except (OSError, ValueError) as exc:
        return f"no answer: {exc}"
    devices = [{k: d.get(k) for k in ("name", "path", "status", "connects", "disconnects", "last_error")}
               | {"counters": {k: v for k, v in (d.get("counters") or {}).items() if v},
                  "events": [{k: e.get(k) for k in ("event", "old", "new", "reason")} for e in d.get("events", [])[-3:]]}
               for d in answer.get("devices", [])]
    return json.dumps({"devices": devices, "simulated_rig": answer.get("simulated_rig"),
                       "device_processes_elsewhere": _device_processes_elsewhere(hub)})


def _device_processes_elsewhere(hub: int) -> list[str]:
    """Device hosts and emulators on this machine whose parent is not the hub `hub` (an earlier
    server's leftovers could hold or reopen a pty the kernel handed to this one)."""
    found = []
    for p in psutil.process_iter(["pid", "ppid", "cmdline"]):
        line = " ".join(p.info["cmdline"] or [])
        if ("devices.device_host_process" in line or "devices.emulator" in line) and p.info["ppid"] != hub:
            found.append(f"{p.info['pid']} (parent {p.info['ppid']}): {line[:120]}")
    return found


def take_the_lease(base: str, token=_REGISTERED) -> dict:
    """Hold the control lease with `token` (the registered admin's by default), taking it from
    another holder (a restarted server's earlier token) if need be: test rigs have one user."""
    answer = get_json(base + "/api/lease", "POST", token=token)
    if answer["status"] == "queued":
        get_json(base + "/api/lease/force-release", "POST", token=token)
        answer = get_json(base + "/api/lease", "POST", token=token)
    if answer["status"] not in ("granted", "held"):
        raise RuntimeError(f"could not take the control lease of {base}: {answer}")
    return answer


def stop_server(proc: subprocess.Popen) -> None:
    proc.terminate()
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    if getattr(proc, "own_data_dir", None):
        shutil.rmtree(proc.own_data_dir, ignore_errors=True)
    ADMIN_TOKENS.pop(getattr(proc, "base_url", None), None)
