"""The hub's handle on the tracker host process (server/tracking/tracker_host_process.py).

Adapter only, in the device host's shape (server/hub/child.py: add_reader, no thread; restart
with backoff). The tracker samples never pass through here: the tracker host sends them to the
loop's tracker UDP port. What comes here is each source's health (every 0.1 s; served by
`GET /api/trackers` as `sources`) and answers to calibration requests.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
from pathlib import Path

from server.hub.child import ChildProcess
from server.ipc.records import FROM_TRACKER_HOST, Answer, Calibrate, Capture, Hello, Record, SourcesHealth, Stop
from server.tracking.sources import SourceSpec

ANSWER_TIMEOUT_S = 5.0


class TrackerHostUnavailable(RuntimeError):
    """The tracker host process did not answer (starting, restarting or stuck)."""


class TrackerHost(ChildProcess):
    what = "tracker host process"
    channel = FROM_TRACKER_HOST

    def __init__(self, specs: tuple[SourceSpec, ...], udp_target: str, data_dir: Path):
        super().__init__()
        self.specs = tuple(specs)
        self.udp_target = udp_target
        self.data_dir = Path(data_dir)
        self.sources: list[dict] = [{"name": s.name, "kind": s.kind, "status": "lost", "reasons": ["starting"]}
                                    for s in self.specs]
        self.info: dict = {}
        self.on_sources = lambda sources: None  # the hub's health hears every report (HealthFeed.on_tracker_sources)

    def _spawn(self, theirs: socket.socket) -> subprocess.Popen:
        proc = subprocess.Popen(
            [sys.executable, "-m", "server.tracking.tracker_host_process", "--control-fd", str(theirs.fileno()),
             "--udp", self.udp_target, "--data-dir", str(self.data_dir)],
            stdin=subprocess.PIPE, pass_fds=(theirs.fileno(),), cwd=os.getcwd(), start_new_session=True)
        proc.stdin.write(json.dumps([s.to_dict() for s in self.specs]).encode())
        proc.stdin.close()
        return proc

    def _on_record(self, record: Record) -> None:
        match record:
            case SourcesHealth(sources):
                self.sources = sources
                self.on_sources(self.sources)
            case Answer(request, result):
                self._answered(request, result)
            case Hello(info):
                self.info = info

    def _closed(self) -> None:
        self._fail_requests(TrackerHostUnavailable("the tracker host process exited (restarting)"))
        self.sources = [dict(s, status="lost", reasons=["tracker host restarting"]) for s in self.sources]
        self.on_sources(self.sources)

    async def capture(self, source: str, seconds: float) -> dict:
        return await self._ask(lambda request: Capture(request, source, float(seconds)), ANSWER_TIMEOUT_S,
                               TrackerHostUnavailable)

    async def calibrate(self, source: str, table: dict | None) -> dict:
        return await self._ask(lambda request: Calibrate(request, source, table), ANSWER_TIMEOUT_S,
                               TrackerHostUnavailable)

    async def stop(self) -> None:
        await self._stop(Stop(), 3.0)
