"""schemathesis against a live server's /openapi.json: every operation, a bounded number of
generated requests each (valid and invalid by the schema, then stateful sequences that follow the
links between operations), with a fixed seed. Every answer must be a documented status with a
body matching its documented schema and content type, and never a server error.

The server is private (its own data directory), so switching scenarios, starting trials and
creating sessions at random harms nothing. The requests carry the harness's admin token, which
holds the control lease (until a generated call releases it: then the rig's operations answer
403, which they document), so the handlers behind the access guard are reached."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.live_server import admin_token, start_server, stop_server

pytest.importorskip("schemathesis")

CHECKS = "not_a_server_error,status_code_conformance,content_type_conformance,response_schema_conformance"
MAX_EXAMPLES = 200  # per operation and phase: about 5,500 requests, under a minute on two cores
SEED = 18


@pytest.mark.slow
def test_every_operation_answers_as_documented(tmp_path):
    proc, base = start_server()
    report = tmp_path / "schemathesis.json"
    try:
        run = subprocess.run(
            [sys.executable, "-m", "schemathesis.cli", "run", f"{base}/openapi.json", "--checks", CHECKS,
             "--max-examples", str(MAX_EXAMPLES), "--seed", str(SEED), "--generation-database", "none",
             "--workers", "1", "--request-timeout", "10", "--no-color",
             "--header", f"Authorization: Bearer {admin_token(base)}",
             "--report", "json", "--report-json-path", str(report)],
            # a bound for a hung run, not a speed check: a loaded or 3x slower machine takes minutes more
            capture_output=True, text=True, timeout=1800, cwd=tmp_path)
    finally:
        stop_server(proc)
    assert report.exists(), run.stdout[-4000:] + run.stderr[-2000:]
    result = json.loads(report.read_text())
    summary = json.dumps(result["failures"], indent=1) + "\n" + run.stdout[-6000:]
    assert result["operations"]["tested"] == result["operations"]["total"] > 20, summary
    assert result["test_cases"]["generated"] > 10 * result["operations"]["total"], summary
    assert result["failures"] == [] and result["errors"] == [], summary
    assert result["exit_code"] == 0 and run.returncode == 0, summary
