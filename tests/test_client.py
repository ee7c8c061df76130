"""`viestac devices`' client of a running server (server/client.py): every failure is one line,
and the product command does not load the bench."""

from __future__ import annotations

import http.server
import json
import subprocess
import sys
import threading

import pytest

from server.client import ServerError, fetch_json


class _Answers(http.server.BaseHTTPRequestHandler):
    """/ok: JSON (the bearer token echoed); /locked: 401; /page: an HTML page, not JSON."""

    def do_GET(self):  # noqa: N802 (http.server's name)
        if self.path == "/locked":
            self.send_error(401, "Unauthorized")
            return
        ok = self.path == "/ok"
        body = json.dumps({"auth": self.headers.get("Authorization")}).encode() if ok else b"<html>hello</html>"
        self.send_response(200)
        self.send_header("Content-Type", "application/json" if ok else "text/html")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, *args):
        pass


@pytest.fixture(scope="module")
def other_server():
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Answers)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}"
    httpd.shutdown()


def test_fetch_json_sends_the_bearer_token(other_server):
    assert fetch_json(other_server + "/ok", token="s3cret") == {"auth": "Bearer s3cret"}
    assert fetch_json(other_server + "/ok") == {"auth": None}


@pytest.mark.parametrize("path, says", [
    ("/locked", "refused: 401 Unauthorized (give --token or $VIESTAC_TOKEN)"),
    ("/page", "is not JSON"),
])
def test_fetch_json_says_in_one_line_why_a_server_did_not_answer(other_server, path, says):
    with pytest.raises(ServerError) as caught:
        fetch_json(other_server + path)
    assert says in str(caught.value) and "\n" not in str(caught.value)


def test_fetch_json_says_no_server_when_nothing_listens():
    with pytest.raises(ServerError, match=r"^no server at http://127\.0\.0\.1:9 \(.*refused.*\)$"):
        fetch_json("http://127.0.0.1:9/api/devices")


def test_viestac_devices_reports_a_page_that_is_not_json_and_never_loads_the_bench(other_server):
    probe = ("import json, sys\n"
             "from server import cli\n"
             f"code = cli.main(['devices', '--json', '--server', {other_server + '/page'!r}])\n"
             "print(json.dumps({'code': code, 'bench': sorted(m for m in sys.modules if m.startswith('server.bench'))}))")
    run = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    *report_lines, last = run.stdout.strip().splitlines()
    report, probed = json.loads("\n".join(report_lines)), json.loads(last)
    assert probed == {"code": 0, "bench": []}
    assert report["server"] is None and "is not JSON" in report["server_error"]
