"""`viestac bench roundtrip`: a browser-style participant on /ws sends a tracker sample → the first
state frame that shows it comes back (its `hip` equals the sent position), with N viewers.

The real server (`viestac serve --port 0`, with its simulated rig), N viewers in the load
generator's process (server/bench/load.py, in the same format), and the participant in this
process, alone in its event loop as in a browser tab. By default it joins after the viewers
(`join="first"`: before them); the hub wakes the senders of a broadcast in the order the clients
joined, participants and operators first, so the join order shows whether that rule holds. It sends a `tracker` message
at `rate_hz` along a path of distinct positions (server/bench/roundtrip.py): in free space the
frames that show the samples come on the 60 Hz cadence; in contact every sample changes the tilt
cue, and the loop publishes a frame in the tick that applies it. Both ends are stamped on
CLOCK_MONOTONIC in this process. The report also says what the server's end of the participant's
connection and the participant's own end had for TCP_NODELAY (server/bench/roundtrip_sockets.py).
"""

from __future__ import annotations

import asyncio
import gc
import socket
import subprocess
import sys
import threading
import time

import websockets

from server.bench.load import hello
from server.bench.loop_bench import off_loop_cpu, token_option
from server.launcher import admin_token, get_json, start_server, stop_server
from server.bench.roundtrip import WHERES, match_samples, sample_position, summarize
from server.bench.roundtrip_sockets import peer_socket_nodelay
from server.wire import codec

SETTLE_S = 1.0  # after a switch of path: the contact gate's dwell and the HIP's jump are not measured


def phase_plan(wheres: tuple[str, ...], seconds: float, warmup_s: float) -> list[tuple[str, float, float]]:
    """(where, unmeasured lead-in s, measured s) per phase: the first waits for the warm-up."""
    return [(where, warmup_s if i == 0 else SETTLE_S, seconds) for i, where in enumerate(wheres)]


async def _participant(url: str, fmt: str, plan: list[tuple[str, float, float]], rate_hz: float,
                       server_pid: int, joined=None) -> tuple[list[list], list[tuple[int, tuple, int]], dict]:
    """Send the samples of every phase and record every state frame. Returns, per phase, the
    measured samples [(send ns, pos)], the frames [(receive ns, hip, tick ns)] and the NODELAY
    findings. `joined`: called (in a thread) once the participant is welcomed, before it sends."""
    frames: list[tuple[int, tuple, int]] = []
    measured: list[list] = [[] for _ in plan]
    async with websockets.connect(url, subprotocols=[f"viestac.v1.{fmt}"], compression=None,
                                  max_size=1 << 21) as ws:
        token = admin_token(url)
        await ws.send(codec.encode({**hello("participant", "bench-roundtrip"), **({"token": token} if token else {})},
                                   fmt))
        own = ws.transport.get_extra_info("socket")
        await ws.recv()  # welcome: the server has accepted by now
        nodelay = {"client_nodelay": bool(own.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY))}
        try:
            nodelay["server_nodelay"] = peer_socket_nodelay(server_pid, own.getsockname())
        except (OSError, LookupError) as exc:  # not Linux ≥ 5.6, or no ptrace access: say so, measure anyway
            nodelay["server_nodelay"] = None
            nodelay["server_nodelay_error"] = str(exc)

        async def read() -> None:
            async for data in ws:
                now = time.monotonic_ns()  # before decoding: the frame is here
                message = codec.decode(data, fmt)
                if message["type"] == "state":
                    frames.append((now, tuple(message["hip"]), round(message["t"] * 1e9)))

        reader = asyncio.create_task(read())
        if joined is not None:
            await asyncio.to_thread(joined)
        k = 0
        next_ns = time.monotonic_ns()
        for index, (where, lead_s, seconds) in enumerate(plan):
            n = max(1, round(seconds * rate_hz))
            # The tracker's clock runs 1/n slow: its phase against the server's 60 Hz frames walks
            # through one whole period during the phase (a browser's display clock drifts against
            # the server's too, only slower), so the percentiles cover every phase, not one.
            period_ns = round(1e9 / rate_hz * (1 + 1 / n))
            lead = max(0, round(lead_s * rate_hz))
            for i in range(lead + n):
                pos = sample_position(where, k)
                t_ns = time.monotonic_ns()
                await ws.send(codec.encode({"type": "tracker", "seq": k, "t": t_ns / 1e6, "pos": list(pos)}, fmt))
                if i >= lead:
                    measured[index].append((t_ns, pos))
                k += 1
                next_ns += period_ns
                await asyncio.sleep(max(0.0, (next_ns - time.monotonic_ns()) / 1e9))
        await asyncio.sleep(0.5)  # the last samples' frames
        reader.cancel()
    return measured, frames, nodelay


JOINS = ("last", "first")


def run_roundtrip_bench(seconds: float = 20.0, clients: int = 0, fmt: str = "msgpack", where: str = "both",
                        rate_hz: float = 60.0, warmup_s: float = 3.0, join: str = "last") -> dict:
    if not 0 < seconds <= 3600:
        raise ValueError(f"seconds must be in (0, 3600], got {seconds}")
    if clients < 0:
        raise ValueError(f"clients must be >= 0, got {clients}")
    if fmt not in codec.FORMATS:
        raise ValueError(f"format must be one of {', '.join(codec.FORMATS)}, got {fmt!r}")
    if where not in (*WHERES, "both"):
        raise ValueError(f"where must be free, contact or both, got {where!r}")
    if not 0 < rate_hz <= 1000:
        raise ValueError(f"rate_hz must be in (0, 1000], got {rate_hz}")
    if warmup_s < 0:
        raise ValueError(f"warmup_s must be >= 0, got {warmup_s}")
    if join not in JOINS:
        raise ValueError(f"join must be one of {', '.join(JOINS)}, got {join!r}")
    plan = phase_plan(WHERES if where == "both" else (where,), seconds, warmup_s)
    total_s = sum(lead + s for _, lead, s in plan)
    proc = load = reset = None
    gc.collect()
    gc.freeze()  # a full collection of the start-up heap here would delay a frame's stamp
    try:
        proc, base = start_server("contact-angle")
        ws_url = base.replace("http://", "ws://") + "/ws"
        window: dict = {}

        def start_viewers() -> None:
            # The viewers run until they are stopped below; their frames are counted by the server.
            nonlocal load, reset
            load = subprocess.Popen([sys.executable, "-m", "server.bench.load", "--url", ws_url, "--viewers",
                                     str(clients), "--trackers", "0", "--format", fmt, "--warmup", "0",
                                     "--seconds", str(total_s + 60), *token_option(base),
                                     *off_loop_cpu(base)],
                                    stdout=subprocess.DEVNULL)
            _wait_viewers(base, clients)
            # The loop's telemetry and the viewers' counters from just before the first measured sample.
            reset = threading.Timer(max(0.0, warmup_s - 0.5), _window_start, (base, window))
            reset.start()

        if join == "last":
            start_viewers()
        measured, frames, nodelay = asyncio.run(_participant(ws_url, fmt, plan, rate_hz, proc.pid,
                                                             start_viewers if join == "first" else None))
        reset.join()
        telemetry = get_json(base + "/api/telemetry")
        viewers = _viewer_counters(base, window)
    finally:
        if reset is not None:
            reset.cancel()
        if load is not None:
            load.terminate()
            load.wait(10)
        if proc is not None:
            stop_server(proc)
        gc.unfreeze()
    result: dict = {"format": fmt, "clients": clients, "join": join, "rate_hz": rate_hz, "seconds": seconds,
                    **nodelay}
    for (phase, _, _), sent in zip(plan, measured):
        result[phase] = summarize(sent, match_samples(sent, frames))
    result.update({**viewers, "period_p99_us": telemetry["period_p99_us"], "overruns": telemetry["overruns"],
                   "rt": telemetry["rt"]})
    return result


def _observers(base: str) -> dict[int, dict]:
    return {c["client_id"]: c for c in get_json(base + "/api/clients") if c["role"] == "observer"}


def _wait_viewers(base: str, clients: int, timeout_s: float = 60.0) -> None:
    """Until every viewer is welcomed (then the participant joins, after them)."""
    deadline = time.monotonic() + timeout_s
    while len(_observers(base)) < clients:
        if time.monotonic() > deadline:
            raise RuntimeError(f"only {len(_observers(base))} of {clients} viewers connected")
        time.sleep(0.1)


def _window_start(base: str, window: dict) -> None:
    get_json(base + "/api/telemetry/reset", "POST")
    window["t"] = time.monotonic()
    window["observers"] = _observers(base)


def _viewer_counters(base: str, window: dict) -> dict:
    """State frames the server sent each viewer per second since the window started, and frames
    it dropped for a viewer that had not taken the previous one yet (latest-wins)."""
    before, now = window.get("observers", {}), _observers(base)
    seconds = time.monotonic() - window["t"]
    sent = [c["frames_sent"] - before[i]["frames_sent"] for i, c in now.items() if i in before]
    dropped = sum(c["frames_dropped"] - before[i]["frames_dropped"] for i, c in now.items() if i in before)
    return {"frames_sent_per_viewer_hz": round(sum(sent) / len(sent) / seconds, 2) if sent else None,
            "viewer_frames_dropped": dropped}
