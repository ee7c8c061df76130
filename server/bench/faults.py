"""`viestac bench faults`: inject every fault of docs/reliability.md into a real server and
measure how it recovers.

Starts `viestac serve` with its simulated rig (the emulators' links and actuator timelines in a
directory of our own, VIESTAC_RIG_DIR), a participant whose tracker presses into the
contact-angle dome (the FerroVibe's tilt is on), a viewer, and a recorded experiment session of a
study written for the bench (one contact-angle trial per fault repetition, no answers needed).
Each repetition starts a trial, injects the fault, waits for recovery and finishes the trial.
/api/health is polled every 5 ms (and `health` messages are taken when the server sends them).
At the end the database says, per completed trial, how many trajectory samples it holds against
how many its ticks call for, and `PRAGMA integrity_check` runs.

The numbers are judged against the issue's acceptance (server/bench/faults_measure.py); a server
that does not report something (no `reasons`, no `health` message) is measured by what it does
report. Times are CLOCK_MONOTONIC of this machine throughout.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from pathlib import Path

import websockets

from server.bench import faults_measure as fm
from server.bench.faults_clients import (CONTACT_POS, Participant, Poller, WsClient, health_status, reason_codes,
                                         slow_readers, udp_tracker)
from server.bench.load import cpu_hogs
from server.bench.loop_bench import token_option
from server.launcher import auth_headers, get_json, start_server, stop_server
from server.core.tool import DRIVER_QUIET_S
from server.hub.child import HEALTHY_S

FAULTS = ("loop_kill", "device_host_kill", "emulator_restart", "device_unplug", "tracker_loss", "key_flood",
          "tracker_flood", "tracker_jitter", "slow_readers", "bad_frames", "huge_values_ws", "huge_values_udp")
RECORD_EVERY = 5
SETTLE_S = 0.4          # a trial runs and the tilt is on before the fault
RECOVER_S = 6.0         # give up waiting for a recovery after this long
START_S = 120.0         # the server's start-up: a loaded machine (load average 25 and hogs) took over 30 s
HEALTH_OK_S = 4.0       # after recovery: how long health may take to say ok again
UNPLUGGED_S = 1.0       # a device stays unplugged this long
FLOOD_S = 1.0
FLOOD_RATE = 10_000     # messages per second
JITTER_RATE = 1000      # tracker samples a second, each 0-1 mm inside the dome somewhere else (issue 35)
JITTER_S = 3.0          # the first DRIVER_QUIET_S of it is the takeover (the tracker rule), the rest is measured
SLOW_READERS = 8
SLOW_READERS_S = 2.0
DEFECT_1 = ((0.0, 1e154, 0.5), (0.0, 1.35e154, 0.5), (0.1, 0.1, 0.5))  # the wedging sequence
REPO = Path(__file__).resolve().parents[2]

STUDY = """id = "bench-faults"
title = "viestac bench faults: contact-angle trials held by the participant's tracker"
seed = 1
participants = 1

[[tasks]]
id = "hold"
scenario = "contact-angle"
device = "ferrovibe"
conditions = [{{ time_limit_s = 600.0 }}]
repetitions = {trials}
order = "fixed"
"""


def ms_since(t0_ns: int, t_ns: int | None) -> float | None:
    return None if t_ns is None else round((t_ns - t0_ns) / 1e6, 3)


def off_ms(t0_ns: int, off_us: int | None) -> float | None:
    """ms from the fault (ns) to an actuator timeline's time (µs)."""
    return None if off_us is None else round((off_us * 1000 - t0_ns) / 1e6, 3)


class Api:
    """The REST calls of the bench, with the session's control token."""

    def __init__(self, base: str):
        self.base = base
        self.token: str | None = None

    def call(self, method: str, path: str, body: dict | None = None) -> tuple[int, dict]:
        data = json.dumps(body).encode() if body is not None else None
        headers = {"Content-Type": "application/json", **auth_headers(self.base),
                   **({"X-Control-Token": self.token} if self.token else {})}
        request = urllib.request.Request(self.base + path, data=data, method=method, headers=headers)
        try:
            with urllib.request.urlopen(request, timeout=10) as response:
                return response.status, json.loads(response.read())
        except urllib.error.HTTPError as exc:
            return exc.code, json.loads(exc.read() or b"{}")

    async def acall(self, method: str, path: str, body: dict | None = None) -> tuple[int, dict]:
        return await asyncio.to_thread(self.call, method, path, body)


class FaultBench:
    def __init__(self, base: str, rig_dir: Path, data_dir: Path):
        self.base, self.rig_dir, self.data_dir = base, rig_dir, data_dir
        self.ws_url = base.replace("http://", "ws://") + "/ws"
        self.api = Api(base)
        self.participant = Participant(self.ws_url)
        self.loop_seen_ns = self.host_seen_ns = time.monotonic_ns()  # when the running processes were first seen
        self.viewer = WsClient(self.ws_url, "observer", name="bench-faults-viewer")
        self.health: Poller | None = None
        self.session_id = ""
        self.timelines: dict[str, list[Path]] = {}   # model -> its timeline files, oldest first
        self.emulators: dict[str, int] = {}          # model -> pid of its running emulator
        self.own_emulators: list[subprocess.Popen] = []
        self.restarts = 0
        self.notes: list[str] = []

    # ---- set-up ---------------------------------------------------------------------------------

    async def setup(self) -> None:
        rig = get_json(self.base + "/api/devices")["simulated_rig"]
        for model, info in rig["emulators"].items():
            self.timelines[model] = [Path(info["timeline"])]
            self.emulators[model] = info["pid"]
        await self.participant.start()
        await self.viewer.connect()
        status, session = await self.api.acall("POST", "/api/sessions", {
            "study": "bench-faults", "participant": f"F{os.getpid()}", "experimenter": "bench", "device": "ferrovibe"})
        if status != 201:
            raise RuntimeError(f"the bench's session was refused: {status} {session}")
        self.session_id, self.api.token = session["id"], session["token"]
        await self.wait_devices_connected(10.0)

    async def wait_devices_connected(self, timeout_s: float) -> None:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            with_suppress = await asyncio.to_thread(_get_or_none, self.base + "/api/devices")
            if with_suppress and with_suppress["devices"] and all(
                    d["status"] == "connected" for d in with_suppress["devices"]):
                return
            await asyncio.sleep(0.05)
        raise RuntimeError("the simulated rig's devices did not connect")

    # ---- trials ---------------------------------------------------------------------------------

    async def start_trial(self) -> tuple[int, int] | None:
        status, view = await self.api.acall("GET", f"/api/sessions/{self.session_id}")
        seq = view.get("next")
        if seq is None:
            return None
        status, started = await self.api.acall("POST", f"/api/sessions/{self.session_id}/trials/{seq}/start")
        if status != 200:
            self.notes.append(f"trial {seq} did not start: {status} {started.get('detail')}")
            return None
        return seq, started.get("attempt", 0)

    async def finish_trial(self, seq: int) -> str:
        status, answer = await self.api.acall("POST", f"/api/sessions/{self.session_id}/trials/{seq}/finish")
        if status == 200:
            return "answered"
        _, view = await self.api.acall("GET", f"/api/sessions/{self.session_id}")
        trial = next((t for t in view.get("trials", []) if t["seq"] == seq), {})
        return trial.get("status", f"finish refused {status}")

    # ---- waiting and observing ------------------------------------------------------------------

    async def until(self, predicate, timeout_s: float = RECOVER_S, every_s: float = 0.005) -> int | None:
        """CLOCK_MONOTONIC ns when `predicate()` first held, None if it did not within the timeout."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if predicate():
                return time.monotonic_ns()
            await asyncio.sleep(every_s)
        return None

    def health_samples(self) -> list[tuple[int, str]]:
        polled = [(t, health_status(a)) for t, a in self.health.samples]
        pushed = [(t, s) for t, s, _ in self.participant.health]
        return sorted(polled + pushed)

    def codes_between(self, t0_ns: int, t1_ns: int) -> list[str] | None:
        seen: set[str] = set()
        reported = False
        for t, answer in list(self.health.samples):
            if t0_ns <= t <= t1_ns and (codes := reason_codes(answer)) is not None:
                reported = True
                seen.update(codes)
        for t, _, codes in self.participant.health:
            if t0_ns <= t <= t1_ns and codes is not None:
                reported = True
                seen.update(codes)
        return sorted(seen) if reported else None

    def read_timelines(self) -> dict[str, list[fm.TimelineRow]]:
        out = {}
        for model, paths in self.timelines.items():
            rows: list[fm.TimelineRow] = []
            for path in paths:
                try:
                    rows += fm.parse_timeline(path.read_text())
                except OSError:
                    pass
            out[model] = rows
        return out

    def latest_health(self) -> dict:
        return self.health.latest() or {}

    async def overruns(self) -> int | None:
        answer = await asyncio.to_thread(_get_or_none, self.base + "/api/telemetry")
        return None if answer is None else answer.get("overruns")

    # ---- one repetition ---------------------------------------------------------------------

    async def repetition(self, kind: str) -> dict:
        trial = await self.start_trial()
        await self.participant.nudge()
        await asyncio.sleep(SETTLE_S)
        overruns_before = await self.overruns()
        rep = await getattr(self, f"fault_{kind}")()
        fault_ns, end_ns = rep.pop("fault_ns"), rep.pop("end_ns")
        # health: degraded after the fault and ok again (process faults); ok at the end (the rest)
        ok_ns = await self.until(lambda: health_status(self.latest_health()) == "ok", HEALTH_OK_S)
        samples = self.health_samples()
        if kind in fm.HEALTH_FAULTS:
            rep["degraded_ms"], rep["ok_ms"] = fm.health_times(samples, fault_ns)
        else:  # an input fault: did health say degraded while it lasted (a wedged loop must)
            rep["degraded_ms"] = fm.health_times(samples, fault_ns, end_ns)[0]
        rep["ok_after"] = ok_ns is not None
        rep["reasons"] = self.codes_between(fault_ns, time.monotonic_ns())
        rep["frames_lost"] = fm.frames_lost(self.participant.state_times(), fault_ns, end_ns, 60.0)
        overruns_after = await self.overruns()
        rep["overruns"] = (overruns_after - overruns_before if None not in (overruns_before, overruns_after)
                           and overruns_after >= overruns_before else None)
        if trial is not None:
            rep["trial"] = {"seq": trial[0], "attempt": trial[1], "status": await self.finish_trial(trial[0])}
        return rep

    async def guarded_repetition(self, kind: str) -> dict:
        """A repetition; one the server did not answer in (a REST call past its 10 s timeout, a
        client's connection closed by its keepalive: both seen on a machine loaded far past its
        cores) is recorded with its error, so its checks fail and the run goes on to report."""
        try:
            return await self.repetition(kind)
        except (TimeoutError, OSError, websockets.ConnectionClosed) as exc:
            self.notes.append(f"{kind}: the repetition failed: {exc!r}")
            for client in (self.participant, self.viewer):
                if client.closed_at is not None:
                    with contextlib.suppress(OSError, TimeoutError, websockets.WebSocketException):
                        await client.connect()
            return {"error": repr(exc)}

    # ---- the faults: each returns its measurements with fault_ns and end_ns ----------------------

    @staticmethod
    async def _up_past_crash_window(seen_ns: int) -> None:
        up_s = (time.monotonic_ns() - seen_ns) / 1e9
        if up_s < HEALTHY_S + 0.2:
            await asyncio.sleep(HEALTHY_S + 0.2 - up_s)

    async def fault_loop_kill(self) -> dict:
        # A loop that dies within HEALTHY_S of its start is a crash loop and waits before its
        # restart (server/hub/child.py RestartBackoff): kill a loop that has been up that long.
        await self._up_past_crash_window(self.loop_seen_ns)
        pid = self.latest_health().get("loop", {}).get("pid")
        t0 = time.monotonic_ns()
        os.kill(pid, signal.SIGKILL)
        first = await self.until(lambda: any(s[2] > t0 for s in self.participant.states[-50:]))
        first_ns = next((s[0] for s in self.participant.states if s[2] > t0), None) if first else None
        await self.until(lambda: self.latest_health().get("loop", {}).get("pid") not in (pid, None))
        new_pid = self.latest_health().get("loop", {}).get("pid")
        self.loop_seen_ns = time.monotonic_ns()
        await asyncio.sleep(0.35)  # the emulators flush their timelines every 0.2 s
        held, off_us = fm.all_off_after(self.read_timelines(), t0 // 1000)
        return {"fault_ns": t0, "end_ns": first_ns or time.monotonic_ns(), "first_state_ms": ms_since(t0, first_ns),
                "held": held, "actuators_off_ms": off_ms(t0, off_us), "loop_pid": [pid, new_pid],
                "loop_pid_changed": new_pid not in (pid, None)}

    async def fault_device_host_kill(self) -> dict:
        await self._up_past_crash_window(self.host_seen_ns)  # as for the loop (fault_loop_kill)
        before = get_json(self.base + "/api/devices")
        pid = before["host"]["pid"]
        with Poller(self.base, "/api/devices", 0.01) as devices:
            t0 = time.monotonic_ns()
            os.kill(pid, signal.SIGKILL)
            back = await self.until(lambda: _all_connected(devices.samples, t0, lambda a: a["host"]["pid"] != pid))
        self.host_seen_ns = time.monotonic_ns()
        await asyncio.sleep(0.35)
        held, off_us = fm.all_off_after(self.read_timelines(), t0 // 1000)
        return {"fault_ns": t0, "end_ns": back or time.monotonic_ns(), "reconnect_ms": ms_since(t0, back),
                "held": held, "actuators_off_ms": off_ms(t0, off_us),
                "host_pid": [pid, (devices.latest() or {}).get("host", {}).get("pid")]}

    async def _replace_emulator(self, model: str, gap_s: float) -> dict:
        """Kill -9 the emulator of `model`; after `gap_s` (the link removed meanwhile, as an
        unplugged device's) start a new one at the same link; wait until the server has it."""
        link = self.rig_dir / model
        before = {d["name"]: d for d in get_json(self.base + "/api/devices")["devices"]}
        connects = before[model].get("connects", 0)
        with Poller(self.base, "/api/devices", 0.01) as devices:
            t0 = time.monotonic_ns()
            os.kill(self.emulators[model], signal.SIGKILL)
            if gap_s > 0:
                link.unlink(missing_ok=True)
                await asyncio.sleep(gap_s)
            self.restarts += 1
            timeline = self.rig_dir / f"{model}-timeline-{self.restarts}.csv"
            proc = subprocess.Popen([sys.executable, "-m", "devices.emulator", model, "--link", str(link),
                                     "--timeline", str(timeline), "--exit-with-parent"], stdout=subprocess.PIPE, text=True, cwd=REPO,
                                    start_new_session=True)
            self.own_emulators.append(proc)
            self.emulators[model] = proc.pid
            self.timelines[model].append(timeline)
            await asyncio.to_thread(proc.stdout.readline)  # "MODEL emulator on PTY": it is there
            plugged = time.monotonic_ns()
            back = await self.until(lambda: _device_back(devices.samples, plugged, model, connects))
        await asyncio.sleep(0.5)  # the held cue reaches the new device; its timeline is flushed
        rows = fm.parse_timeline(timeline.read_text()) if timeline.exists() else []
        shown = next((r.t_us for r in rows if r.on), None)
        return {"fault_ns": t0, "end_ns": back or time.monotonic_ns(), "plugged_ms": ms_since(t0, plugged),
                "reconnect_ms": ms_since(plugged, back), "from_kill_ms": ms_since(t0, back),
                "cue_reapplied": shown is not None, "cue_reapplied_ms": off_ms(plugged, shown)}

    async def fault_emulator_restart(self) -> dict:
        return await self._replace_emulator("ferrovibe", 0.0)

    async def fault_device_unplug(self) -> dict:
        return await self._replace_emulator("ferrovibe", UNPLUGGED_S)

    async def fault_tracker_loss(self) -> dict:
        """The participant's tracker goes silent while it presses (its samples carry a ttl, as a
        hand tracker's do; the connection stays open), then sends again."""
        self.participant.ttl_ms = fm.TRACKER_TTL_MS
        await asyncio.sleep(0.2)  # samples with the ttl are applied
        t0 = time.monotonic_ns()
        self.participant.paused = True
        await asyncio.sleep(1.2)
        held, off_us = fm.all_off_after(self.read_timelines(), t0 // 1000)
        codes = self.codes_between(t0, time.monotonic_ns())
        back = time.monotonic_ns()
        self.participant.paused = False
        await asyncio.sleep(0.1)
        self.participant.ttl_ms = None  # held as before between samples (other faults pause it)
        return {"fault_ns": t0, "end_ns": back, "held": held, "actuators_off_ms": off_ms(t0, off_us),
                "tracker_lost_reported": "tracker_lost" in (codes or ())}

    async def _flood(self, what: str, rate: int = FLOOD_RATE, seconds: float = FLOOD_S, skip_s: float = 0.0) -> dict:
        """A second participant, in a process of its own, sends `rate` messages a second for
        `seconds`; the viewer's frames before and during, and how long /api/health took to answer."""
        proc = await asyncio.create_subprocess_exec(
            sys.executable, "-m", "server.bench.faults_clients", "--url", self.ws_url, "--what", what,
            "--rate", str(rate), "--seconds", str(seconds), *token_option(self.ws_url), stdout=asyncio.subprocess.PIPE, cwd=REPO)
        out, _ = await proc.communicate()
        flood = json.loads(out.decode().strip().splitlines()[-1])
        t0, t1 = flood["t0_ns"], flood["t1_ns"]
        window = int(1e9)
        before_t0 = t0 - window  # the viewer's rate before: the second before the flood
        t0 += int(skip_s * 1e9)  # the flood's effect from here on (the jitter's takeover)
        states = self.viewer.states
        before = [s[3] for s in states if before_t0 <= s[0] < before_t0 + window]
        during = [s[3] for s in states if t0 <= s[0] <= t1]
        times = self.viewer.state_times()
        rate_before, rate_during = fm.rate_hz(times, before_t0, before_t0 + window), fm.rate_hz(times, t0, t1)
        return {"fault_ns": t0, "end_ns": t1, "sent_per_s": round(flood["sent"] / ((t1 - t0) / 1e9)),
                "frame_bytes_before": fm.median(before), "frame_bytes_during": fm.median(during),
                "frame_growth": round(fm.median(during) / fm.median(before), 2) if before and during else None,
                "viewer_hz_before": rate_before, "viewer_hz_during": rate_during,
                "loop_states_per_s": _published_per_s(self.viewer.published, t0, t1),
                "rate_kept": round(rate_during / rate_before, 3) if rate_before and rate_during is not None else None,
                "health_slowest_ms": self.health.slowest_ms(t0, t1),
                "flooder_errors": flood["error_codes"], "flooder_closed": flood["closed"]}

    async def fault_key_flood(self) -> dict:
        return await self._flood("key")

    async def fault_tracker_flood(self) -> dict:
        return await self._flood("tracker")

    async def fault_tracker_jitter(self) -> dict:
        """The jittering tracker must drive the HIP (the storm is the driver's): the participant
        goes quiet first, so the jitter takes over after DRIVER_QUIET_S (the tracker rule); the
        window is from then on."""
        self.participant.paused = True
        try:
            rep = await self._flood("jitter", JITTER_RATE, JITTER_S, skip_s=DRIVER_QUIET_S)
        finally:
            self.participant.paused = False
        return rep

    async def fault_slow_readers(self) -> dict:
        times = self.viewer.state_times
        t0 = time.monotonic_ns()
        with slow_readers(self.base, SLOW_READERS):
            await asyncio.sleep(SLOW_READERS_S)
        t1 = time.monotonic_ns()
        before, during = fm.rate_hz(times(), t0 - int(1e9), t0), fm.rate_hz(times(), t0 + int(0.5e9), t1)
        return {"fault_ns": t0, "end_ns": t1, "viewer_hz_before": before, "viewer_hz_during": during,
                "rate_kept": round(during / before, 3) if before and during is not None else None,
                "health_slowest_ms": self.health.slowest_ms(t0, t1),
                "viewer_frames_lost": fm.frames_lost(times(), t0, t1, 60.0)}

    async def fault_bad_frames(self) -> dict:
        frames = {"deep_nesting": '{"type":"tracker","seq":1,"t":0,"pos":' + "[" * 2000 + "]" * 2000 + "}",
                  "seq_2_64": '{"type":"tracker","seq":18446744073709551616,"t":0,"pos":[0,0,1]}',
                  "t_400_digits": '{"type":"tracker","seq":1,"t":' + "9" * 400 + ',"pos":[0,0,1]}'}
        t0 = time.monotonic_ns()
        outcome = {}
        for name, text in frames.items():
            client = WsClient(self.ws_url, "participant", fmt="json", name="bench-faults-bad")
            await client.connect()
            await asyncio.sleep(0.1)
            errors = len(client.errors)
            await client.send_raw(text)
            await self.until(lambda c=client, n=errors: len(c.errors) > n or c.closed_at is not None, 1.0)
            await asyncio.sleep(0.2)
            outcome[name] = {"error_reply": [c for _, c in client.errors[errors:]], "open": client.closed_at is None}
            await client.close()
        return {"fault_ns": t0, "end_ns": time.monotonic_ns(), "frames": outcome,
                "stayed_open": all(o["open"] and o["error_reply"] for o in outcome.values())}

    async def _huge_values(self, send, tag: float) -> dict:
        """The issue's defect-1 sequence, then sane samples at 100 Hz (the sane position shifted by
        `tag` so a frame that shows it is one of these): do state frames keep coming, and does a
        frame show the sane sample?"""
        sane = (CONTACT_POS[0], CONTACT_POS[1], round(CONTACT_POS[2] + tag, 9))
        for pos in DEFECT_1:
            await send(pos)
            await asyncio.sleep(0.005)  # each in a tick of its own
        t0 = time.monotonic_ns()
        states = self.participant.states
        n0 = len(states)

        async def sane_samples() -> None:
            while True:
                await send(sane)
                await asyncio.sleep(0.01)

        task = asyncio.create_task(sane_samples())
        try:
            resumed = await self.until(lambda: any(s[2] > t0 for s in states[n0:]), 1.5)
            shown = await self.until(lambda: any(s[2] > t0 and s[4] == sane for s in states[n0:]), 1.5)
        finally:
            task.cancel()
        first_ns = next((s[0] for s in states[n0:] if s[2] > t0), None) if resumed else None
        shown_ns = next((s[0] for s in states[n0:] if s[2] > t0 and s[4] == sane), None) if shown else None
        rep = {"fault_ns": t0, "end_ns": time.monotonic_ns(), "resume_ms": ms_since(t0, first_ns),
               "recovered": shown_ns is not None, "recovered_ms": ms_since(t0, shown_ns)}
        if shown_ns is None:  # a wedged loop: restart it so the next faults measure something
            self.notes.append("huge values wedged the loop; the bench killed it to go on")
            os.kill(self.latest_health().get("loop", {}).get("pid"), signal.SIGKILL)
            rep["restored_by_bench"] = True
            n1 = len(states)
            await self.until(lambda: len(states) > n1 + 10, RECOVER_S)
        return rep

    async def fault_huge_values_ws(self) -> dict:
        self.participant.paused = True
        try:
            return await self._huge_values(self.participant.tracker, 1e-6)
        finally:
            self.participant.paused = False

    async def fault_huge_values_udp(self) -> dict:
        address = self.latest_health().get("tracker_udp")
        if not address:
            return {"fault_ns": time.monotonic_ns(), "end_ns": time.monotonic_ns(), "skipped": "no tracker UDP port"}
        send_udp = udp_tracker(address)

        async def send(pos) -> None:
            send_udp(pos)
        self.participant.paused = True
        await asyncio.sleep(1.1)  # the /ws driver quiet for DRIVER_QUIET_S: the UDP bridge takes over
        try:
            return await self._huge_values(send, 2e-6)
        finally:
            send_udp.close()
            self.participant.paused = False
            await asyncio.sleep(1.1)  # the participant drives again once the bridge is quiet

    async def close(self) -> None:
        await self.participant.stop()
        await self.viewer.close()
        for proc in self.own_emulators:
            if proc.poll() is None:
                proc.terminate()
        for proc in self.own_emulators:
            try:
                proc.wait(3)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


def _published_per_s(published: list[tuple[int, int]], t0_ns: int, t1_ns: int) -> float | None:
    """State records the loop published a second between t0 and t1, from the publish counter of
    the frames a viewer got (frames the hub held back count too)."""
    inside = [(t, n) for t, n in published if t0_ns <= t <= t1_ns]
    if len(inside) < 2 or inside[-1][0] <= inside[0][0]:
        return None
    return round((inside[-1][1] - inside[0][1]) / ((inside[-1][0] - inside[0][0]) / 1e9), 1)


def _get_or_none(url: str) -> dict | None:
    try:
        return get_json(url, timeout=2.0)
    except (OSError, ValueError):
        return None


def _all_connected(samples: list, t0: int, also) -> bool:
    return any(t > t0 and a and a.get("devices") and all(d["status"] == "connected" for d in a["devices"]) and also(a)
               for t, a in samples[-5:])


def _device_back(samples: list, t0: int, name: str, connects: int) -> bool:
    for t, a in samples[-5:]:
        if t > t0 and a:
            d = next((d for d in a.get("devices", []) if d["name"] == name), None)
            if d and d["status"] == "connected" and d.get("connects", 0) > connects:
                return True
    return False


def count_samples(db_path: Path, reps: dict[str, list[dict]], every: int, tick_hz: float) -> dict:
    """Per repetition whose trial attempt completed (answered): trajectory rows recorded against
    rows its ticks call for; sets rep["samples_lost"]. Returns the totals and the integrity check."""
    db = sqlite3.connect(f"file:{db_path}?mode=ro", uri=True)
    try:
        totals = {"completed_trials": 0, "interrupted": 0, "expected": 0, "recorded": 0, "lost": 0,
                  "tick_clock_jumps": 0}
        for kind_reps in reps.values():
            for rep in kind_reps:
                trial = rep.get("trial")
                if not trial:
                    continue
                row = db.execute("SELECT id, status, attempt, started_tick, ended_tick, started_utc, ended_utc "
                                 "FROM trials WHERE seq = ?", (trial["seq"],)).fetchone()
                if row is None or row[1] not in ("answered", "excluded") or row[2] != trial["attempt"]:
                    totals["interrupted"] += 1
                    continue
                tid, _, attempt, started, ended = row[:5]
                recorded = db.execute("SELECT COUNT(*) FROM samples WHERE trial_id = ? AND attempt = ?",
                                      (tid, attempt)).fetchone()[0]
                expected = fm.expected_samples(started, ended, every)
                wall_s = _wall_s(row[5], row[6])
                if not fm.ticks_agree(started, ended, tick_hz, wall_s):  # the tick clock went back or jumped
                    totals["tick_clock_jumps"] += 1
                    rep["tick_clock_jump"] = True
                    expected = round(wall_s * tick_hz / every)
                rep["samples_lost"] = max(0, expected - recorded)
                totals["completed_trials"] += 1
                totals["expected"] += expected
                totals["recorded"] += recorded
                totals["lost"] += rep["samples_lost"]
        totals["integrity_check"] = db.execute("PRAGMA integrity_check").fetchone()[0]
        return totals
    finally:
        db.close()


def _wall_s(started_utc: str | None, ended_utc: str | None) -> float:
    from datetime import datetime
    if not started_utc or not ended_utc:
        return 0.0
    return (datetime.fromisoformat(ended_utc) - datetime.fromisoformat(started_utc)).total_seconds()


def report(reps: dict[str, list[dict]], notes: list[str], samples: dict, repeat: int, seconds: float) -> dict:
    faults = {}
    for kind, kind_reps in reps.items():
        checks = fm.judge(kind, kind_reps)
        times = {key: fm.stats([r.get(key) for r in kind_reps]) for key in
                 ("first_state_ms", "actuators_off_ms", "reconnect_ms", "degraded_ms", "ok_ms", "resume_ms")
                 if any(key in r for r in kind_reps)}
        faults[kind] = {"pass": fm.passed(checks), "checks": [c.to_dict() for c in checks], "times_ms": times,
                        "overruns": sum(r["overruns"] for r in kind_reps if r.get("overruns") is not None),
                        "frames_lost": sum(r.get("frames_lost") or 0 for r in kind_reps),
                        "samples_lost": sum(r.get("samples_lost") or 0 for r in kind_reps),
                        "reasons": sorted({c for r in kind_reps for c in (r.get("reasons") or ())}),
                        "repetitions": kind_reps}
    ok = all(f["pass"] for f in faults.values()) and samples.get("integrity_check") == "ok" and not samples["lost"]
    return {"pass": ok, "repeat": repeat, "seconds": round(seconds, 1), "faults": faults, "samples": samples,
            "notes": notes}


async def _run(bench: FaultBench, kinds: tuple[str, ...], repeat: int, progress) -> dict[str, list[dict]]:
    reps: dict[str, list[dict]] = {}
    await bench.setup()
    with Poller(bench.base, "/api/health", 0.005) as health:
        bench.health = health
        try:
            for kind in kinds:
                for i in range(repeat):
                    if progress:
                        progress(f"{kind} {i + 1}/{repeat}")
                    reps.setdefault(kind, []).append(await bench.guarded_repetition(kind))
        finally:
            await bench.close()
    return reps


def run_fault_bench(repeat: int = 3, kinds: tuple[str, ...] = FAULTS, progress=None, keep: Path | None = None,
                    load: int = 0) -> dict:
    """Run the faults `repeat` times each; `keep`: a new directory that keeps the database, the
    rig's timelines and the study (else everything goes with the run); `load`: that many CPU hogs
    run beside the server, from before it starts until it stopped (server/bench/load.py)."""
    if load < 0:
        raise ValueError(f"load must be >= 0, got {load}")
    with cpu_hogs(load):
        result = _run_fault_bench(repeat, kinds, progress, keep)
    result["load"] = load
    return result


def run_loaded_and_unloaded(repeat: int, kinds: tuple[str, ...], load: int, progress=None,
                            keep: Path | None = None) -> dict:
    """`viestac bench faults --load N`: the bench on a quiet machine, then with N CPU hogs; it
    passes when both do."""
    runs = {}
    for name, hogs in (("unloaded", 0), (f"loaded ({load} CPU hogs)", load)):
        if progress:
            progress(name)
        try:
            runs[name] = run_fault_bench(repeat, kinds, progress, None if keep is None else keep / name.split()[0],
                                         hogs)
        except RuntimeError as exc:  # e.g. the server did not start in time: the other run still reports
            runs[name] = {"pass": False, "error": str(exc), "load": hogs, "faults": {}, "samples": {},
                          "repeat": repeat, "seconds": 0.0}
    return {"pass": all(r["pass"] for r in runs.values()), "load": load, "runs": runs}


def _run_fault_bench(repeat: int, kinds: tuple[str, ...], progress, keep: Path | None) -> dict:
    if repeat < 1:
        raise ValueError(f"repeat must be >= 1, got {repeat}")
    unknown = [k for k in kinds if k not in FAULTS]
    if unknown:
        raise ValueError(f"unknown fault {', '.join(unknown)}; one of {', '.join(FAULTS)}")
    if keep is not None:
        keep.mkdir(parents=True)  # must be new: the bench's database and timelines only
    work = keep if keep is not None else Path(tempfile.mkdtemp(prefix="viestac-faults-"))
    rig_dir, data_dir, studies = work / "rig", work / "data", work / "studies"
    studies.mkdir()
    (studies / "bench-faults.toml").write_text(STUDY.format(trials=len(kinds) * repeat + 5))
    env_before = os.environ.get("VIESTAC_RIG_DIR")
    os.environ["VIESTAC_RIG_DIR"] = str(rig_dir)  # the server's rig: links and timelines where we look
    start = time.monotonic()
    proc = None
    try:
        proc, base = start_server("contact-angle", extra=["--data-dir", str(data_dir), "--studies", str(studies),
                                                          "--record-every", str(RECORD_EVERY)],
                                  timeout_s=START_S)
        tick_hz = get_json(base + "/api/health")["loop"]["tick_hz"]
        bench = FaultBench(base, rig_dir, data_dir)
        reps = asyncio.run(_run(bench, tuple(kinds), repeat, progress))
        for client in (bench.participant, bench.viewer):
            if client.unreadable:
                bench.notes.append(f"{client.name}: {len(client.unreadable)} frames not understood, e.g. "
                                   f"{client.unreadable[0]}")
        stop_server(proc)
        proc = None
        samples = count_samples(data_dir / "viestac.sqlite", reps, RECORD_EVERY, tick_hz)
        return report(reps, bench.notes, samples, repeat, time.monotonic() - start)
    finally:
        if proc is not None:
            stop_server(proc)
        if env_before is None:
            os.environ.pop("VIESTAC_RIG_DIR", None)
        else:
            os.environ["VIESTAC_RIG_DIR"] = env_before
        if keep is None:
            shutil.rmtree(work, ignore_errors=True)
