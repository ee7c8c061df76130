"""`viestac bench loop`: the real server, real WebSocket clients, loop timing and memory.

Starts `viestac serve` as its own process tree (hub + loop), runs the load generator in a third
process, resets the loop's cumulative telemetry after the warm-up, and samples the resident
memory of every server process together. The numbers come from the server's own telemetry
(the loop's measured periods and tick costs), not from the client side.

`start_server` is also the tests' harness. Each server it starts gets an admin token of its own
(env VIESTAC_ADMIN_TOKEN: held in the server's memory only), takes the control lease with it, and
registers it in ADMIN_TOKENS, so `get_json` on that server's URLs sends it and WebSocket clients
find it with `admin_token(url)`; a load generator in another process gets it as an argument.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.parse
import urllib.request

import psutil

from server.auth.tokens import new_secret
from server.bench.floor import run_floor
from server.bench.kernel_trace import LoopWakeTrace, summarize
from server.bench.quantiles import tail


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


def token_option(url: str) -> list[str]:
    """The bench client processes' `--token=SECRET` for the server at `url`, as one argument: any
    secret passes so, even one starting with "-" (new_secret never draws one, other tokens may),
    which as a separate argument is read as an option and the client exits with a usage error."""
    token = admin_token(url)
    return [f"--token={token}"] if token else []


def auth_headers(url: str, token=_REGISTERED) -> dict[str, str]:
    """The Authorization header for a request to `url`: `token`, or the registered one by default
    (`token=None`: none)."""
    if token is _REGISTERED:
        token = admin_token(url)
    return {"Authorization": f"Bearer {token}"} if token else {}


def get_json(url: str, method: str = "GET", timeout: float = 5.0, body: dict | None = None,
             token=_REGISTERED) -> dict:
    """GET (or POST, DELETE with an optional JSON body) a URL of the server and decode its JSON
    answer; HTTP errors raise urllib.error.HTTPError (its .code and .read() carry the detail).
    Sends `token` as the bearer token; by default the one start_server registered for that
    server (`token=None`: no token)."""
    data = json.dumps(body).encode() if body is not None else None
    headers = {"Content-Type": "application/json"} if data is not None else {}
    headers.update(auth_headers(url, token))
    request = urllib.request.Request(url, data=data, method=method, headers=headers)
    with urllib.request.urlopen(request, timeout=timeout) as response:
        return json.loads(response.read())


UNLIMITED_OVERRUNS = 10_000  # the largest threshold: every tick of a 10 s window late


LEASE_TTL_S = 86400  # the harness's lease lasts the run (a test that studies expiry passes --lease-ttl)


def start_server(scenario: str = "contact-angle", extra: list[str] | None = None,
                 timeout_s: float = 30.0, *, take_lease: bool = True) -> tuple[subprocess.Popen, str]:
    """Start `viestac serve --port 0`; return the process and its base URL once healthy, with an
    admin token registered for it (ADMIN_TOKENS) that holds the control lease (unless not
    `take_lease`)."""
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
    proc = subprocess.Popen([sys.executable, "-m", "server.cli", "serve", "--port", "0", "--scenario", scenario,
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
        if ("devices.host_process" in line or "devices.emulator" in line) and p.info["ppid"] != hub:
            found.append(f"{p.info['pid']} (parent {p.info['ppid']}): {line[:120]}")
    return found


def off_loop_cpu(base: str, plan: dict | None = None) -> list[str]:
    """The load generator's `--cpus` when the server keeps its loop's CPU to itself
    (`--loop-cpu own`): the viewers stand in for remote clients, which do not run there either.
    `plan`: the server's `loop.cpus` from /api/health, if the caller has it already."""
    plan = (plan if plan is not None else get_json(base + "/api/health")["loop"].get("cpus")) or {}
    return ["--cpus", ",".join(map(str, plan["others"]))] if plan.get("own") else []


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


def _tree_rss_mb(pid: int) -> float:
    try:
        root = psutil.Process(pid)
        procs = [root, *root.children(recursive=True)]
    except psutil.NoSuchProcess:
        return 0.0
    total = 0
    for p in procs:
        try:
            total += p.memory_info().rss
        except psutil.NoSuchProcess:
            pass
    return total / 2**20


def _rss_summary(samples: list[tuple[float, float]], seconds: float) -> dict:
    """Peak RSS, and start/end/growth from the medians of the first and last window (10 s, or a
    quarter of a short run) so one sample (a transient allocation) does not decide the growth."""
    if not samples:
        return {"rss_mb": None, "rss_start_mb": None, "rss_end_mb": None, "rss_growth_mb": None}
    window = min(10.0, seconds / 4)
    first = [mb for t, mb in samples if t <= window] or [samples[0][1]]
    last = [mb for t, mb in samples if t >= samples[-1][0] - window] or [samples[-1][1]]
    start, end = statistics.median(first), statistics.median(last)
    return {"rss_mb": round(max(mb for _, mb in samples), 1), "rss_start_mb": round(start, 1),
            "rss_end_mb": round(end, 1), "rss_growth_mb": round(end - start, 1)}


def run_loop_bench(seconds: float = 10.0, viewers: int = 8, trackers: int = 2, warmup_s: float = 3.0,
                   scenario: str = "contact-angle", kernel_trace: bool = False, loop_cpu: str = "auto",
                   floor_s: float = 3.0) -> dict:
    """Loop timing and memory of the real server under load. `kernel_trace` also records the
    loop's timed wake-ups with the kernel's tracer (root, tracefs) and says what made late ones
    late (server/bench/kernel_trace.py). First, for `floor_s` seconds a pattern (0: not at all),
    the machine's floor under a tick in the same CPU plan (server/bench/floor.py): the baseline of
    the same run that the tick cost is read against."""
    if seconds <= 0:
        raise ValueError(f"seconds must be > 0, got {seconds}")
    if viewers < 0 or trackers < 0:
        raise ValueError(f"viewers and trackers must be >= 0, got {viewers} and {trackers}")
    if warmup_s < 0:
        raise ValueError(f"warmup_s must be >= 0, got {warmup_s}")
    if floor_s < 0:
        raise ValueError(f"floor_s must be >= 0, got {floor_s}")
    if kernel_trace:
        LoopWakeTrace.check()  # before anything starts: a clear error, nothing to clean up
    floor = run_floor(floor_s, loop_cpu) if floor_s else {}  # before the server: the machine alone
    proc, base = start_server(scenario, ["--loop-cpu", loop_cpu])
    wake_trace = None
    try:
        ws_url = base.replace("http://", "ws://") + "/ws"
        cpus = get_json(base + "/api/health")["loop"]["cpus"]
        load = subprocess.Popen([sys.executable, "-m", "server.bench.load", "--url", ws_url, "--viewers", str(viewers),
                                 "--trackers", str(trackers), "--warmup", str(warmup_s), "--seconds", str(seconds),
                                 *token_option(base), *off_loop_cpu(base, cpus)],
                                stdout=subprocess.PIPE, text=True)
        time.sleep(warmup_s)
        if kernel_trace:
            buffer_kb = int(min(256 * 1024, 8192 + 400 * seconds))  # the whole window up to ~10 min
            wake_trace = LoopWakeTrace(get_json(base + "/api/health")["loop"]["pid"], buffer_kb=buffer_kb)
            wake_trace.start()
        get_json(base + "/api/telemetry/reset", "POST")
        start = time.monotonic()
        end = start + seconds
        rss_samples: list[tuple[float, float]] = []  # (seconds since the reset, MB)
        while time.monotonic() < end:
            rss_samples.append((time.monotonic() - start, _tree_rss_mb(proc.pid)))
            time.sleep(0.25)
        telemetry = get_json(base + "/api/telemetry")
        wakeups = wake_trace.stop() if wake_trace is not None else None
        tracker_rows = get_json(base + "/api/trackers?limit=4096")["rows"]
        out, _ = load.communicate(timeout=60)
        load_result = json.loads(out.strip().splitlines()[-1])
    finally:
        try:
            if wake_trace is not None and wake_trace.instance.exists():
                wake_trace.stop()  # an error on the way: still remove the trace instance
        finally:
            stop_server(proc)
    # The bench's trackers stamp `t` with CLOCK_MONOTONIC in ms (same machine, same clock), so
    # applied - t is the whole path: WebSocket send, hub read and validation, mailbox, next tick.
    send_to_tick = sorted((row[4] - row[2] * 1e6) / 1e6 for row in tracker_rows)
    hub_to_tick = sorted((row[4] - row[3]) / 1e6 for row in tracker_rows)

    rss = _rss_summary(rss_samples, seconds)
    return {
        "period_p50_us": telemetry["period_p50_us"], "period_p99_us": telemetry["period_p99_us"],
        "period_p999_us": telemetry["period_p999_us"], "period_max_us": telemetry["period_max_us"],
        "overruns": telemetry["overruns"], "ticks": telemetry["ticks"],
        "tick_cost_p50_us": telemetry["tick_cost_p50_us"], "tick_cost_p99_us": telemetry["tick_cost_p99_us"],
        "tick_cost_max_us": telemetry["tick_cost_max_us"],
        # the ticks that published a state record (every cue change and the 60 Hz frames) and the others
        **{k: telemetry[k] for k in ("published_ticks", "tick_cost_published_p50_us", "tick_cost_published_p99_us",
                                     "tick_cost_quiet_p50_us", "tick_cost_quiet_p99_us")},
        "clients": viewers, "trackers": trackers,
        "frames_received_per_client_hz": load_result["frames_received_per_client_hz"]["mean"],
        "frames_received_per_client_hz_min": load_result["frames_received_per_client_hz"]["min"],
        "tracker_messages": load_result["tracker_messages"],
        **tail(send_to_tick, "tracker_to_tick_", "_ms", (("p50", 0.5), ("p99", 0.99))),
        **tail(hub_to_tick, "hub_to_tick_", "_ms", (("p99", 0.99),)), "tracker_samples": len(send_to_tick),
        **rss, "rt": telemetry["rt"], "loop_cpu": cpus, "seconds": seconds, "resyncs": telemetry["resyncs"],
        **({"kernel_trace": {**summarize(wakeups), "lost_events": wake_trace.lost_events}}
           if wakeups is not None else {}),
        **floor,
    }
