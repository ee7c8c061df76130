"""`viestac` command line: serve, render, bench."""

from __future__ import annotations

import argparse
import json
import logging
import socket
import sys

from scenarios.registry import UnknownScenario
from server.scene import SceneError


def _serve(args: argparse.Namespace) -> int:
    import uvicorn

    from server.app import create_app
    from server.config import Settings

    settings = Settings(host=args.host, port=args.port, scenario=args.scenario, scene_file=args.scene,
                        state_hz=args.state_hz, realtime=not args.no_realtime, gate_band=args.gate_band,
                        gate_dwell_s=args.gate_dwell_ms / 1000.0)
    app = create_app(settings)
    family = socket.AF_INET6 if ":" in settings.host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind((settings.host, settings.port))  # bind first so --port 0 can print the real port
    port = sock.getsockname()[1]
    shown_host = f"[{settings.host}]" if family == socket.AF_INET6 else settings.host
    print(f"ViESTac serving scenario {settings.scenario} on http://{shown_host}:{port}/  "
          f"(WebSocket ws://{shown_host}:{port}/ws, API docs http://{shown_host}:{port}/docs)", flush=True)
    config = uvicorn.Config(app, ws="websockets-sansio", ws_max_size=settings.max_frame_bytes,
                            ws_per_message_deflate=False, log_level=args.log_level, access_log=False)
    uvicorn.Server(config).run(sockets=[sock])
    return 0


def _render(args: argparse.Namespace) -> int:
    from server.render import TrajectoryError, make_simulation, read_trajectory, render

    try:
        sim = make_simulation(args.scene)
        samples = read_trajectory(args.trajectory)
    except (SceneError, TrajectoryError, UnknownScenario, OSError, ValueError) as exc:
        print(f"viestac render: {exc}", file=sys.stderr)
        return 2
    ticks = render(sim, samples, args.out)
    print(f"wrote {ticks} ticks to {args.out}")
    return 0


def _bench_loop(args: argparse.Namespace) -> int:
    from server.bench.loop_bench import run_loop_bench

    result = run_loop_bench(seconds=args.seconds, viewers=args.clients, trackers=args.trackers,
                            warmup_s=args.warmup, scenario=args.scenario)
    if args.json:
        print(json.dumps(result))
    else:
        for key, value in result.items():
            print(f"{key:32s} {value}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="viestac", description="ViESTac tactile evaluation server")
    sub = parser.add_subparsers(dest="command", required=True)

    serve = sub.add_parser("serve", help="run the server with a simulated rig (no hardware needed)")
    serve.add_argument("--host", default="127.0.0.1")
    serve.add_argument("--port", type=int, default=8000, help="0 picks a free port (printed)")
    serve.add_argument("--scenario", default="contact-angle")
    serve.add_argument("--scene", default=None, help="a scene JSON file to explore instead of the scenario's scene")
    serve.add_argument("--state-hz", type=float, default=60.0)
    serve.add_argument("--gate-band", type=float, default=0.002,
                       help="contact hysteresis band in scene units (default 0.002)")
    serve.add_argument("--gate-dwell-ms", type=float, default=30.0,
                       help="minimum on/off time of the debounced contact (default 30 ms)")
    serve.add_argument("--no-realtime", action="store_true", help="do not ask for SCHED_FIFO for the loop")
    serve.add_argument("--log-level", default="info", choices=["critical", "error", "warning", "info", "debug"])
    serve.set_defaults(func=_serve)

    render = sub.add_parser("render", help="run a recorded HIP trajectory through a scene (virtual clock)")
    render.add_argument("--scene", required=True, help="a scenario name (e.g. contact-angle) or a scene JSON file")
    render.add_argument("--trajectory", required=True, help="CSV with columns t,x,y,z")
    render.add_argument("--out", required=True, help="output CSV, one row per tick")
    render.set_defaults(func=_render)

    bench = sub.add_parser("bench", help="benchmarks")
    bench_sub = bench.add_subparsers(dest="bench", required=True)
    loop = bench_sub.add_parser("loop", help="loop timing with N viewers at 60 Hz and tracker clients at 120 Hz")
    loop.add_argument("--seconds", type=float, default=10.0)
    loop.add_argument("--clients", type=int, default=8, help="viewer clients")
    loop.add_argument("--trackers", type=int, default=2)
    loop.add_argument("--warmup", type=float, default=3.0)
    loop.add_argument("--scenario", default="contact-angle")
    loop.add_argument("--json", action="store_true", help="print one JSON object")
    loop.set_defaults(func=_bench_loop)
    return parser


def main(argv: list[str] | None = None) -> int:
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(levelname)s %(message)s")
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (UnknownScenario, SceneError, ValueError) as exc:
        print(f"viestac: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
