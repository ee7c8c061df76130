"""Live servers for the transport tests: one on http, one on https with a `viestac tls init`
certificate. Started here (not with the bench harness) to read every line they print."""

from __future__ import annotations

import os
import re
import secrets
import shutil
import ssl
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from server import tls
from tests.live_server import UNLIMITED_OVERRUNS

URL_LINE = re.compile(r"on (https?://\S+?)/ ")  # the banner's shape (server.cli.serve_banner)


@dataclass
class Served:
    proc: subprocess.Popen
    base: str
    data_dir: Path
    admin_token: str
    lines: list[str] = field(default_factory=list)
    ca: Path | None = None

    @property
    def port(self) -> int:
        return int(self.base.rsplit(":", 1)[1])

    def ssl_context(self) -> ssl.SSLContext | None:
        return ssl.create_default_context(cafile=str(self.ca)) if self.ca else None


def launch(extra: list[str], ca: Path | None = None, timeout_s: float = 40.0) -> Served:
    data_dir = Path(tempfile.mkdtemp(prefix="viestac-transport-"))
    token = secrets.token_urlsafe(32)
    env = {**os.environ, "VIESTAC_ADMIN_TOKEN": token}
    proc = subprocess.Popen([sys.executable, "-m", "server.cli", "serve", "--port", "0", "--log-level", "warning",
                             "--no-realtime", "--overrun-threshold", str(UNLIMITED_OVERRUNS), "--tracker-udp", "off",
                             "--data-dir", str(data_dir), *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
    served = Served(proc, "", data_dir, token, ca=ca)
    deadline = time.monotonic() + timeout_s
    while not served.base:
        line = proc.stdout.readline()
        if not line:
            raise RuntimeError(f"server exited early with code {proc.wait()}: {served.lines}")
        served.lines.append(line)
        match = URL_LINE.search(line)
        if match:
            served.base = match.group(1)
    # the login link follows the banner; keep reading in the background (never block on a full pipe)
    threading.Thread(target=lambda: [served.lines.append(x) for x in proc.stdout], daemon=True).start()
    while True:
        try:
            with urllib.request.urlopen(served.base + "/", timeout=2, context=served.ssl_context()) as r:
                if r.status == 200:
                    return served
        except OSError:
            pass
        if time.monotonic() > deadline:
            stop(served)
            raise RuntimeError(f"server did not answer in time: {served.lines}")
        time.sleep(0.1)


def stop(served: Served) -> None:
    served.proc.terminate()
    try:
        served.proc.wait(10)
    except subprocess.TimeoutExpired:
        served.proc.kill()
        served.proc.wait()
    shutil.rmtree(served.data_dir, ignore_errors=True)


@pytest.fixture(scope="session")
def http_server():
    served = launch([])
    yield served
    stop(served)


@pytest.fixture(scope="session")
def tls_files(tmp_path_factory):
    return tls.init(tmp_path_factory.mktemp("tls"), ["localhost"], ["127.0.0.1"])


@pytest.fixture(scope="session")
def https_server(tls_files):
    served = launch(["--tls-cert", str(tls_files.path("cert")), "--tls-key", str(tls_files.path("key"))],
                    ca=tls_files.path("ca"))
    yield served
    stop(served)


def get(served: Served, path: str, headers: dict | None = None) -> tuple[int, dict, bytes]:
    request = urllib.request.Request(served.base + path, headers=headers or {})
    try:
        with urllib.request.urlopen(request, timeout=5, context=served.ssl_context()) as r:
            return r.status, dict(r.headers), r.read()
    except urllib.error.HTTPError as err:
        return err.code, dict(err.headers), err.read()
