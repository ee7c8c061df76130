"""`viestac` command line: serve, devices, emulate, render, export, analyze, bench, token."""

from __future__ import annotations

import argparse
import json
import logging
import os
import socket
import ssl
import sys
from pathlib import Path

from server.core.scenario import ParamError
from scenarios.registry import UnknownScenario
from server.config import STUDIES_DIR
from server.core.haptics import contact_gate as gate_defaults
from server.cpu_plan import MODES, OWN_FROM_CPUS, keep_off_loop_cpu, plan_cpus
from server.log_repeats import limit_repeats
from server.loop.cadence import STATE_HZ
from server.loop.tracker_udp import is_loopback
from server.core.scene import SceneError


def _fingers(texts: list[str]) -> tuple[tuple[str, str], ...]:
    """--finger NAME=POINT, repeatable; ValueError for one without '=' (Settings checks the rest)."""
    pairs = []
    for text in texts:
        name, eq, point = text.partition("=")
        if not eq or not name or not point:
            raise ValueError(f"--finger {text!r}: expected NAME=POINT, e.g. fingertac=right.thumb.tip")
        pairs.append((name, point))
    return tuple(pairs)


def _serve(args: argparse.Namespace) -> int:
    import uvicorn

    from server.app import create_app
    from server.config import Settings

    from devices.manager import DeviceConfig, DeviceConfigError, load_device_file

    try:
        devices = [DeviceConfig.parse(text) for text in args.device]
        if args.devices:
            devices += load_device_file(args.devices)
    except DeviceConfigError as exc:
        print(f"viestac serve: {exc}", file=sys.stderr)
        return 2
    from devices.profiles import ProfileError

    try:
        settings = Settings(host=args.host, port=args.port, scenario=args.scenario,
                            scenario_params=_scenario_params(args.param), scene_file=args.scene,
                            state_hz=args.state_hz, realtime=not args.no_realtime, loop_cpu=args.loop_cpu,
                            gate_band=args.gate_band,
                            gate_dwell_s=args.gate_dwell_ms / 1000.0, devices=tuple(devices),
                            simulated_rig=not args.no_rig, rig_models=tuple(m for m in args.rig.split(",") if m),
                            data_dir=Path(args.data_dir), studies_dir=Path(args.studies),
                            record_every=args.record_every, force=args.force, tracker_udp=args.tracker_udp,
                            overrun_threshold=args.overrun_threshold, lease_ttl_s=args.lease_ttl,
                            tls_cert=Path(args.tls_cert) if args.tls_cert else None,
                            tls_key=Path(args.tls_key) if args.tls_key else None,
                            allowed_hosts=tuple(args.allow_host), allowed_origins=tuple(args.allow_origin),
                            login_link=not args.no_login_link, fingers=_fingers(args.finger),
                            trackers=tuple(args.tracker))
    except (ParamError, ProfileError, ValueError) as exc:
        print(f"viestac serve: {exc}", file=sys.stderr)
        return 2
    plan = plan_cpus(os.sched_getaffinity(0), settings.loop_cpu)
    keep_off_loop_cpu(plan)  # before any thread or child starts: they inherit it
    report = settings.capability()
    if not report.ok and not args.force:
        print(f"viestac serve: {report.message} (--force runs it anyway)", file=sys.stderr)
        return 2
    from server.loop import tracker_udp

    address = settings.tracker_address()
    try:
        tracker_sock = tracker_udp.bind(address) if address is not None else None
    except OSError as exc:
        print(f"viestac serve: {exc.strerror}", file=sys.stderr)
        return 2
    if settings.tls_cert is not None:
        try:  # a mismatched or unreadable pair fails here, with its reason, not at the first connection
            ssl.create_default_context(ssl.Purpose.CLIENT_AUTH).load_cert_chain(settings.tls_cert, settings.tls_key)
        except (ssl.SSLError, OSError) as exc:
            print(f"viestac serve: TLS certificate {settings.tls_cert} / key {settings.tls_key}: {exc}", file=sys.stderr)
            return 2
    app = create_app(settings, tracker_sock=tracker_sock, cpu_plan=plan)
    sock = listen_socket(settings.host, settings.port)  # bound first so --port 0 can print the real port
    port = sock.getsockname()[1]
    # Test and bench harnesses read the base URL from the first line: "on http(s)://HOST:PORT/ ".
    print(serve_banner(settings, port), flush=True)
    if plan.own:
        print(f"the loop has CPU {plan.loop} to itself; the other server processes run on CPU "
              f"{','.join(map(str, sorted(plan.others)))} (--loop-cpu {settings.loop_cpu})", flush=True)
    if tracker_sock is not None:
        print("tracker samples by UDP to %s:%d (docs/protocol.md)" % tracker_sock.getsockname()[:2], flush=True)
    if not is_loopback(settings.host) and settings.tls_cert is None:
        print(exposure_warning(settings.host, port), file=sys.stderr, flush=True)
    if settings.login_link:
        code = _login_code(app, settings)
        print(f"Log in to the console (admin, single use, valid {LOGIN_LINK_TTL_S // 60} min): "
              f"{link_base(settings, port)}/console.html#login={code}", flush=True)
    from server.hub.ws_transport import BoundedWebSocketProtocol  # websockets-sansio, its send path bounded

    config = uvicorn.Config(app, ws=BoundedWebSocketProtocol, ws_max_size=settings.max_frame_bytes,
                            ws_per_message_deflate=False, log_level=args.log_level, access_log=False,
                            ssl_certfile=settings.tls_cert, ssl_keyfile=settings.tls_key)
    uvicorn.Server(config).run(sockets=[sock])
    return 0


LOGIN_LINK_TTL_S = 3600


def _login_code(app, settings) -> str:
    """A single-use admin login code in the server's access database (like a notebook server's
    token URL: the one who started the server can open the console without a step)."""
    access = getattr(app.state, "access", None)
    if access is not None:
        return access.book.create_code("login", role="admin", ttl_s=LOGIN_LINK_TTL_S)
    from server.auth import open_book

    store, book = open_book(settings.data_dir)  # the same file the server reads
    try:
        return book.create_code("login", role="admin", ttl_s=LOGIN_LINK_TTL_S)
    finally:
        store.close()


def _url_host(host: str) -> str:
    return f"[{host}]" if ":" in host else host


def serve_banner(settings, port: int) -> str:
    """The start-up line: where the pages, the WebSocket and the API docs are."""
    web, ws, shown = settings.scheme, ("wss" if settings.tls_cert else "ws"), _url_host(settings.host)
    return (f"ViESTac serving scenario {settings.scenario} on {web}://{shown}:{port}/  "
            f"(WebSocket {ws}://{shown}:{port}/ws, API docs {web}://{shown}:{port}/docs)")


def link_base(settings, port: int) -> str:
    """scheme://host:port a browser on this machine can open: the bound address, or for a wildcard
    bind a name the certificate (and the Host allow-list) holds."""
    host = settings.host
    if host in ("", "0.0.0.0", "::"):
        host = "localhost"
        if settings.tls_cert is not None:
            from server.tls import certificate_names

            names = certificate_names(settings.tls_cert)
            host = "localhost" if "localhost" in names or not names else names[0]
    return f"{settings.scheme}://{_url_host(host)}:{port}"


def exposure_warning(host: str, port: int) -> str:
    return (f"WARNING: serving on {host}:{port} without TLS. Anyone on the network can reach the pages, the API "
            "and /ws (they still need a token), and everything crosses the network in clear text: tokens, login "
            "and join links, scene and state, participants' answers and session data. Browsers on other machines "
            "also get no secure context (no WebXR). Make a certificate with `viestac tls init` and pass "
            "--tls-cert/--tls-key (docs/security.md).")


def _tls(args: argparse.Namespace) -> int:
    from server import tls

    directory = Path(args.dir) if args.dir else Path(args.data_dir) / "tls"
    names = ([] if args.no_defaults else tls.default_names()) + list(args.name)
    ips = ([] if args.no_defaults else tls.lan_addresses()) + list(args.ip)
    issued = tls.init(directory, names, ips, new_ca=args.new_ca)
    cert, key, ca = issued.path("cert"), issued.path("key"), issued.path("ca")
    print(f"{'new' if issued.new_ca else 'existing'} local CA: {ca}  (trust it once on each headset and browser)")
    print(f"server certificate: {cert}  key: {key} (0600)")
    print(f"  names: {', '.join(issued.names) or '-'}")
    print(f"  IPs:   {', '.join(issued.ips) or '-'}")
    print(f"  SPKI sha256: {tls.spki_sha256(cert)}")
    print(f"serve with: viestac serve --host 0.0.0.0 --tls-cert {cert} --tls-key {key}")
    return 0


def listen_socket(host: str, port: int) -> socket.socket:
    """The server's TCP socket, bound, for uvicorn. Every connection accepted on it has
    TCP_NODELAY: without it, Nagle's algorithm holds a state frame while the previous one is
    unacknowledged, until the client's next message carries the ACK or its delayed-ACK timer
    (40 ms on Linux) fires: tracker → state took one tracker period (p50 17 ms), at worst 44 ms
    (docs/performance.md, "Tracker → state round trip"). asyncio sets TCP_NODELAY on an accepted
    connection only when the socket object says IPPROTO_TCP, and accept() copies the proto of the
    listening socket object, 0 unless given here. Linux also copies the listener's TCP_NODELAY
    into every accepted socket, so it holds under any event loop uvicorn picks."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM, socket.IPPROTO_TCP)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    sock.bind((host, port))
    return sock


def _scenario_params(pairs: list[str]) -> dict:
    """KEY=VALUE pairs; VALUE is read as JSON when it parses (30, true, "x"), else as a string."""
    params = {}
    for pair in pairs:
        key, sep, raw = pair.partition("=")
        if not sep or not key:
            raise ParamError(f"--param {pair!r}: expected KEY=VALUE")
        try:
            params[key] = json.loads(raw)
        except json.JSONDecodeError:
            params[key] = raw
    return params


def _devices(args: argparse.Namespace) -> int:
    """Serial ports the OS reports, devices configured in a file, and a running server's devices."""
    from devices.manager import DeviceConfigError, load_device_file
    from devices.ports import list_ports, resolve
    from server.client import ServerError, fetch_json

    report: dict = {"ports": list_ports(), "configured": [], "server": None}
    if args.devices:
        try:
            configs = load_device_file(args.devices)
        except DeviceConfigError as exc:
            print(f"viestac devices: {exc}", file=sys.stderr)
            return 2
        report["configured"] = [{"name": c.name, "model": c.profile.model, "port": c.where,
                                 "resolves_to": resolve(c.port) if c.port is not None else None, "table_2_2": c.profile.table_row()} for c in configs]
    try:
        report["server"] = fetch_json(f"{args.server.rstrip('/')}/api/devices", timeout=2.0, token=args.token)
    except ServerError as exc:
        report["server_error"] = str(exc)
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    print("Serial ports:" if report["ports"] else "Serial ports: none")
    for p in report["ports"]:
        line = f"  {p['device']:24s} {p.get('description') or ''}"
        if p.get("vid"):
            line += f"  [usb:{p['vid']}:{p['pid']}{':' + p['serial_number'] if p.get('serial_number') else ''}]"
        if p.get("latency_timer_ms") is not None:
            line += f"  latency timer {p['latency_timer_ms']} ms"
        print(line)
        if p.get("warning"):
            print(f"    warning: {p['warning']}")
    for c in report["configured"]:
        where = ("an audio output, looked for when the server starts" if c["port"].startswith("audio:")
                 else "the participant's page, connected when it offers an actuator" if c["port"].startswith("browser:")
                 else "present at " + c["resolves_to"] if c["resolves_to"] else "not present")
        print(f"Configured {c['name']} ({c['model']}) on {c['port']}: {where}")
    if report["server"] is None:
        print(report["server_error"])
        return 0
    print(f"Devices of the server at {args.server}:")
    for d in report["server"]["devices"]:
        ident = d.get("identity") or {}
        fw = f" firmware {ident['fw_major']}.{ident['fw_minor']}.{ident['fw_patch']}" if ident else ""
        rtt = f", rtt {d['rtt_ms']} ms" if d.get("rtt_ms") is not None else ""
        c = d.get("counters", {})
        rejected = sum(v for k, v in c.items() if k in ("framing", "too_long", "bad_length", "bad_crc", "unknown_type"))
        print(f"  {d['name']:12s} {d['status']:13s} {d['profile']['model']}{fw} on {d.get('path') or d['port']}{rtt}, "
              f"{c.get('frames_out', 0)} frames out, {c.get('frames_in', 0)} in, {rejected} rejected, "
              f"{d.get('disconnects', 0)} disconnects")
        if d.get("warning"):
            print(f"    warning: {d['warning']}")
    for r in report["server"]["refusals"]:
        print(f"  refused: {r['reason']}")
    return 0


EMULATED = ("fingertac", "ferrovibe", "devkit", "leap")


def _emulate(args: argparse.Namespace) -> int:
    if args.rest[:1] in (["-h"], ["--help"]):  # the kinds; each kind has its own --help
        print(f"usage: viestac emulate {{{','.join(EMULATED)}}} [options]\n\n"
              "Emulate a tactile device on a pseudo-terminal (fingertac, ferrovibe, devkit) or the Leap Motion "
              "service's WebSocket (leap).\nOptions of each: viestac emulate KIND --help")
        return 0
    if args.rest[:1] == ["leap"]:  # the Leap Motion service's WebSocket (server/tracking/leap_emulator.py)
        from server.tracking.leap_emulator import main as leap_main

        return leap_main(args.rest[1:])
    if args.rest[:1] == ["audio"]:  # a JACK dummy server and a capture (devices/audio/emulator.py)
        from devices.audio.emulator import main as audio_main

        return audio_main(args.rest[1:])
    from devices.emulator import main as emulate_main

    return emulate_main(args.rest)


def _render(args: argparse.Namespace) -> int:
    from server.render import TrajectoryError, make_simulation, read_trajectory, render

    try:
        sim = make_simulation(args.scene, tools=tuple(args.tool))
        samples = read_trajectory(args.trajectory)
    except (SceneError, TrajectoryError, UnknownScenario, OSError, ValueError) as exc:
        print(f"viestac render: {exc}", file=sys.stderr)
        return 2
    ticks = render(sim, samples, args.out)
    print(f"wrote {ticks} ticks to {args.out}")
    return 0


def _export(args: argparse.Namespace) -> int:
    from server.experiment.export import ExportError, database_path, export

    if (args.session is None) == (not args.all):
        print("viestac export: give a SESSION_ID or --all (one of them)", file=sys.stderr)
        return 2
    try:
        summaries = export(database_path(args.data_dir), args.out, args.session, all_sessions=args.all,
                           force=args.force, site=args.site)
    except ExportError as exc:
        print(f"viestac export: {exc}", file=sys.stderr)
        return 2
    for s in summaries:
        what = f"session {s['session']}: {s['trials']} trials" if s["session"] else f"{s['trials']} trials in total"
        print(f"{s.get('file') or s['dir']}  {what}, {s['written']} files written, {s['unchanged']} unchanged"
              + (f", {s['removed']} removed" if s["removed"] else ""))
    return 0


def _without_extra(command: str, extra: str) -> bool:
    """True, after saying in one line how to install it, when `extra` is missing (exit 2)."""
    from server.extras import needs

    line = needs(command, extra)
    if line:
        print(line, file=sys.stderr)
    return line is not None


def _analyze(args: argparse.Namespace) -> int:
    if _without_extra("viestac analyze", "analysis"):
        return 2
    from server.analysis.load import AnalysisError
    from server.analysis.run import analyze

    if args.workers is not None and args.workers < 1:
        print("viestac analyze: --workers must be at least 1", file=sys.stderr)
        return 2
    try:
        stats = analyze(args.data, args.out, study=args.study, workers=args.workers)
    except AnalysisError as exc:
        print(f"viestac analyze: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"viestac analyze: cannot write to {args.out}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    prov = stats["provenance"]
    print(f"analysed {prov['n_sessions']} sessions ({prov['n_participants']} participants) of study "
          f"{prov['study_id']}: {Path(args.out) / 'report.html'}, {Path(args.out) / 'stats.json'}")
    for path, reason in stats["skipped"].items():
        print(f"  skipped {path}: {reason}")
    return 0


def _report_devices(args: argparse.Namespace) -> int:
    if _without_extra("viestac report devices", "analysis"):
        return 2
    from server.analysis.load import AnalysisError
    from server.report.run import PAGE, STATS, report_devices

    try:
        stats = report_devices(args.data, args.out, rig=args.rig)
    except AnalysisError as exc:
        print(f"viestac report devices: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"viestac report devices: cannot write to {args.out}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    for card in stats["devices"]:
        print(f"{card['model']}: " + ", ".join(f"{p['part']} {p['status']}" for p in card["parts"]))
    print(f"report card: {Path(args.out) / PAGE}, {Path(args.out) / STATS}")
    return 0


def _study(args: argparse.Namespace) -> int:
    if args.simulate == args.power:
        print("viestac study: give --simulate (one simulated study) or --power (power analysis); a real study "
              "runs from the console", file=sys.stderr)
        return 2
    try:
        participants = _participant_list(args.participants)
        from server.simulate.effects import parse_settings

        people = parse_settings(args.set)
    except ValueError as exc:
        print(f"viestac study: {exc}", file=sys.stderr)
        return 2
    if args.power:
        return _study_power(args, participants)
    if len(participants) != 1:
        print("viestac study: --simulate runs one study: give one number of --participants", file=sys.stderr)
        return 2
    from server.simulate.study_run import progress_bar, simulate_study

    if args.workers is not None and args.workers < 1:
        print("viestac study: --workers must be at least 1", file=sys.stderr)
        return 2
    try:
        result = simulate_study(args.study, participants=participants[0], seed=args.seed, out_dir=args.out,
                                make_participant=people.participant, agent_params=people.agent,
                                settings=people.settings, progress=None if args.quiet else progress_bar,
                                workers=args.workers or len(os.sched_getaffinity(0)),
                                on_cpu_free=None if args.no_analysis else _preload_analysis)
    except FileExistsError as exc:
        print(f"viestac study: {exc}", file=sys.stderr)
        return 2
    print(f"{result.trials} trials of {len(result.sessions)} synthetic participants in {result.wall_s:.0f} s "
          f"({result.virtual_s:.0f} s of virtual time); {len(result.aborted)} aborted; data in {result.data_dir}")
    for participant, seq, reason in result.aborted:
        print(f"  aborted: {participant} trial {seq}: {reason}")
    if args.no_analysis:
        return 0
    return _analyze_after_simulation(result.data_dir, Path(args.out) / "report")


def _battery(args: argparse.Namespace) -> int:
    from devices.profiles import ProfileError
    from server.battery.parts import plan_for
    from server.battery.study_file import battery_study, extra_tasks

    try:
        targets = _part_assignments(args.target_se, "--target-se", float)
        trials = _part_assignments(args.trials, "--trials", int)
        if args.trial_counts:
            return _battery_trial_counts(targets, args.observers, args.seed)
        if not args.device or not args.out:
            raise ValueError("--device and --out are required (or --trial-counts for the power analysis alone)")
        if targets:
            from server.simulate.battery_trial_counts import counts_for_targets
            trials = {**counts_for_targets(targets, args.observers, args.seed), **trials}
        extra = extra_tasks(Path(args.add_parts).read_text(encoding="utf-8"), args.add_parts) if args.add_parts else ()
        text = battery_study(args.device, extra, participants=args.participants, trials=trials)
    except (ProfileError, ValueError, OSError) as exc:  # StudyError is a ValueError: it names the field
        print(f"viestac battery: {exc}", file=sys.stderr)
        return 2
    Path(args.out).write_text(text, encoding="utf-8")
    plans = plan_for(args.device, trials)
    for plan in plans:
        breaks = f"{plan.breaks} break{'s' if plan.breaks != 1 else ''}"
        print(f"  {plan.part.id:<22} " + (f"{plan.trials:>4} trials {breaks:>8} {plan.minutes:>5.1f} min" if plan.runs
                                           else f"skipped: {plan.reason}"))
    print(f"{sum(p.minutes for p in plans if p.runs):.1f} min per participant; written to {args.out}")
    return 0


def _battery_trial_counts(targets: dict, observers: int, seed: int) -> int:
    """Print the battery's power analysis; say whether parts.TRIALS is what it derives."""
    from server.simulate import battery_trial_counts as trial_counts
    from server.battery.parts import TRIALS

    counts, rows = trial_counts.derive(observers=observers, seed=seed, targets=targets)
    print(trial_counts.report(counts, rows, observers, seed))
    differ = {k: (TRIALS[k], c.trials) for k, c in counts.items() if TRIALS[k] != c.trials}
    if differ:
        print("differs from the battery's defaults (server/battery/parts.py TRIALS): "
              + ", ".join(f"{k} {old} -> {new}" for k, (old, new) in differ.items()))
    else:
        print("the battery's defaults (server/battery/parts.py TRIALS) are these counts")
    return 0


def _part_assignments(values: list[str] | None, option: str, kind: type) -> dict:
    """["stiffness=0.05", ...] as {"stiffness": 0.05}; ValueError naming the bad one."""
    out = {}
    for value in values or ():
        name, sep, number = value.partition("=")
        try:
            if not sep or not name.strip():
                raise ValueError
            out[name.strip()] = kind(number)
        except ValueError:
            raise ValueError(f"{option} takes PART={'N' if kind is int else 'VALUE'} (e.g. stiffness="
                             f"{'40' if kind is int else '0.05'}), got {value!r}") from None
    return out


def _participant_list(text: str) -> list[int]:
    """"13" or "8,12,16": whole numbers >= 1."""
    try:
        values = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise ValueError(f"--participants takes whole numbers separated by commas, got {text!r}") from None
    if not values or min(values) < 1:
        raise ValueError(f"--participants must be at least 1, got {text!r}")
    return values


def _study_power(args: argparse.Namespace, participants: list[int]) -> int:
    if _without_extra("viestac study --power", "power"):
        return 2
    import functools

    from server.simulate.power import run_power, text_table
    from server.simulate.threshold_power import psychophysics_tasks

    try:
        psychophysics = bool(psychophysics_tasks(Path(args.study).read_text(encoding="utf-8")))
    except (ValueError, OSError):
        psychophysics = False  # unreadable, or not TOML: the study loader below says why
    if psychophysics:
        return _threshold_power(args, participants)
    if args.trials or args.target_se_db is not None:
        print("viestac study: --trials and --target-se-db are for a psychophysics study (a task with "
              "[tasks.psychophysics]); this one's power is over --participants", file=sys.stderr)
        return 2
    result = _replications(args, functools.partial(
        run_power, args.study, participants, args.replications, out=args.out, seed=args.seed, settings=args.set,
        alpha=args.alpha, workers=args.workers, scheduler=args.scheduler))
    if isinstance(result, int):
        return result
    print(f"power at alpha = {args.alpha:g} over {args.replications} replications per N "
          f"({result.computed} run now, {result.reused} stored) in {result.wall_s:.0f} s:")
    print(text_table(result.table, sorted(set(participants))))
    print(f"table and chart: {result.out / 'power.json'}, {result.out / 'power.csv'}, {result.out / 'power.png'}")
    return 0


def _replications(args: argparse.Namespace, run):
    """A power analysis's run (`run(progress=…)`), or the exit code of its refusal or interruption."""
    import functools

    from server.simulate.study_run import progress_bar

    try:
        return run(progress=None if args.quiet else functools.partial(progress_bar, unit="replications"))
    except (ValueError, OSError) as exc:  # bad settings or grid, another configuration in --out (StudyError too)
        print(f"viestac study: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"\nviestac study: interrupted; the finished replications are stored in {args.out}: the same command "
              "continues", file=sys.stderr)
        return 130


def _threshold_power(args: argparse.Namespace, participants: list[int]) -> int:
    """--power on a psychophysics study: the threshold's SE per trial count (docs/power.md)."""
    import functools

    from server.simulate.threshold_power import TARGET_SE_DB, run_threshold_power, text_table

    if len(participants) != 1:
        print("viestac study: --power on a psychophysics study simulates one group: give one number of "
              "--participants (the trial counts are --trials)", file=sys.stderr)
        return 2
    try:
        trials = [int(t) for t in args.trials.split(",") if t.strip()] if args.trials else None
    except ValueError:
        print(f"viestac study: --trials takes whole numbers separated by commas, got {args.trials!r}", file=sys.stderr)
        return 2
    result = _replications(args, functools.partial(
        run_threshold_power, args.study, participants[0], args.replications, out=args.out, trials=trials,
        target_se_db=TARGET_SE_DB if args.target_se_db is None else args.target_se_db, seed=args.seed,
        settings=args.set, workers=args.workers, scheduler=args.scheduler))
    if isinstance(result, int):
        return result
    print(f"threshold standard error over {args.replications} × {participants[0]} simulated participants "
          f"({result.computed} replications run now, {result.reused} stored) in {result.wall_s:.0f} s:")
    print(text_table(result.table, result.trials))
    print(f"table and chart: {result.out / 'threshold_power.json'}, {result.out / 'threshold_power.csv'}, "
          f"{result.out / 'threshold_power.png'}")
    return 0


def _preload_analysis() -> None:
    """The analysis's libraries loaded in a thread while the last participants run."""
    import threading

    def load() -> None:
        try:
            from server.analysis.run import preload

            preload()
        except ImportError:
            pass  # said after the simulation, by _analyze_after_simulation

    global _preloading
    _preloading = threading.Thread(target=load, name="analysis-preload", daemon=True)
    _preloading.start()


_preloading = None  # the preload thread, joined before the analysis (which draws in forked processes)


def _analyze_after_simulation(data_dir: Path, out: Path) -> int:
    if _preloading is not None:
        _preloading.join()  # done by now (it ran beside the last participants); a fork needs no other thread
    if _without_extra("the analysis after the study", "analysis"):  # the data stay, for `viestac analyze` later
        return 0
    from server.analysis.run import analyze  # the analysis of `viestac analyze`
    analyze(data_dir, out)
    print(f"report: {out / 'report.html'}")
    return 0


def _bench_loop(args: argparse.Namespace) -> int:
    from server.bench.kernel_trace import KernelTraceUnavailable
    from server.bench.loop_bench import run_loop_bench

    try:
        result = run_loop_bench(seconds=args.seconds, viewers=args.clients, trackers=args.trackers,
                                warmup_s=args.warmup, scenario=args.scenario, kernel_trace=args.kernel_trace,
                                loop_cpu=args.loop_cpu, floor_s=args.floor_seconds)
    except KernelTraceUnavailable as exc:
        print(f"viestac: {exc}", file=sys.stderr)
        return 2
    return _print_bench(result, args.json)


def _bench_floor(args: argparse.Namespace) -> int:
    from server.bench.floor import run_floor

    every = {} if args.publish_every is None else {"publish_every": args.publish_every}
    return _print_bench(run_floor(seconds=args.seconds, loop_cpu=args.loop_cpu, **every), args.json)


def _print_bench(result: dict, as_json: bool) -> int:
    """One JSON object, or one aligned `key value` line per result."""
    if as_json:
        print(json.dumps(result))
    else:
        width = max(map(len, result), default=0) + 2
        for key, value in result.items():
            print(f"{key:{width}s} {value}")
    return 0


def _bench_link(args: argparse.Namespace) -> int:
    from server.bench.link_bench import run_link_bench

    result = run_link_bench(seconds=args.seconds, rate_hz=args.rate, share=args.share)
    return _print_bench(result, args.json)


def _bench_audio(args: argparse.Namespace) -> int:
    if _without_extra("viestac bench audio", "audio"):
        return 2
    from server.bench.audio_bench import run_audio_bench

    result = run_audio_bench(blocks=tuple(args.block or (32, 64, 128, 256)), cues=args.cues,
                             realtime=False if args.no_realtime else None)
    return _print_bench(result, args.json)


def _bench_latency(args: argparse.Namespace) -> int:
    from server.bench.latency_bench import run_latency_bench

    result = run_latency_bench(seconds=args.seconds, clients=args.clients, warmup_s=args.warmup, tracker=args.tracker,
                               samples=args.samples)
    return _print_bench(result, args.json)


def _bench_tracking(args: argparse.Namespace) -> int:
    from server.bench.tracking_bench import run_tracking_bench

    result = run_tracking_bench(Path(args.out), latency_seconds=args.latency_seconds, viewers=args.viewers)
    print(json.dumps(result, indent=None if args.json else 1))
    return 0


def _bench_roundtrip(args: argparse.Namespace) -> int:
    from server.bench.roundtrip_bench import run_roundtrip_bench

    result = run_roundtrip_bench(seconds=args.seconds, clients=args.clients, fmt=args.format, where=args.where,
                                 rate_hz=args.rate, warmup_s=args.warmup, join=args.join)
    return _print_bench(result, args.json)


def _bench_accuracy(args: argparse.Namespace) -> int:
    from server.bench.accuracy import run_accuracy_bench

    result = run_accuracy_bench(Path(args.out), quick=args.quick)
    return _print_bench(result, args.json)


def _bench_objects(args: argparse.Namespace) -> int:
    from server.bench.objects import run_objects_bench

    result = run_objects_bench(Path(args.out), quick=args.quick)
    return _print_bench(result, args.json)


def _bench_stability(args: argparse.Namespace) -> int:
    from server.bench.stability import run_stability_bench

    result = run_stability_bench(Path(args.out), quick=args.quick)
    return _print_bench(result, args.json)


def _bench_xr(args: argparse.Namespace) -> int:
    from server.bench.xr_bench import run_xr_bench

    return _print_bench(run_xr_bench(touches=args.touches, seconds=args.seconds), args.json)


def _bench_switch(args: argparse.Namespace) -> int:
    from server.bench.switch_bench import run_switch_bench

    result = run_switch_bench(args.switches, args.every_ms / 1e3, start=args.start)
    return _print_bench(result, args.json)


def _bench_psychophysics(args: argparse.Namespace) -> int:
    from server.bench.psychophysics import run_psychophysics_bench

    return _print_bench(run_psychophysics_bench(quick=args.quick), args.json)


def _bench_intervals(args: argparse.Namespace) -> int:
    from server.bench.intervals_bench import run_intervals_bench

    result = run_intervals_bench(intervals=args.intervals, quick=args.quick, loop_cpu=args.loop_cpu)
    return _print_bench(result, args.json)


def _bench_faults(args: argparse.Namespace) -> int:
    from server.bench.faults import FAULTS, run_fault_bench, run_loaded_and_unloaded
    from server.bench.faults_measure import table

    kinds = tuple(k for k in args.only.split(",") if k) if args.only else FAULTS
    progress = None if args.json else (lambda what: print(f"  {what}", file=sys.stderr, flush=True))
    keep = Path(args.keep) if args.keep else None
    if args.load > 0:
        result = run_loaded_and_unloaded(args.repeat, kinds, args.load, progress, keep)
        text = "\n\n".join(f"== {name}\n{table(run)}" for name, run in result["runs"].items())
    else:
        result = run_fault_bench(repeat=args.repeat, kinds=kinds, progress=progress, keep=keep)
        text = table(result)
    print(json.dumps(result) if args.json else text)
    return 1 if args.check and not result["pass"] else 0


def _ttl_s(text: str) -> float | None:
    """`30d`, `12h`, `45m`, `90s` or `none` (no expiry) as seconds."""
    if text.lower() in ("none", "never"):
        return None
    units = {"s": 1, "m": 60, "h": 3600, "d": 86400}
    number, unit = text[:-1], text[-1:].lower()
    try:
        value = float(number) * units[unit]
    except (KeyError, ValueError):
        raise ValueError(f"--ttl {text!r}: a number with s, m, h or d (30d, 12h), or none") from None
    if not value > 0:
        raise ValueError(f"--ttl {text!r} must be positive")
    return value


def _utc(seconds: float | None) -> str:
    import datetime

    if seconds is None:
        return "never"
    return datetime.datetime.fromtimestamp(seconds, datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")


def _token(args: argparse.Namespace) -> int:
    """Tokens of DATA_DIR/access.sqlite; a running server on the same data directory sees the change at once."""
    from server.auth import open_book

    store, book = open_book(Path(args.data_dir))
    try:
        if args.token == "create":
            secret, ident = book.create(args.role, args.site, session=args.session, label=args.label,
                                        ttl_s=_ttl_s(args.ttl), created_by="cli")
            if args.json:
                print(json.dumps({"token": secret, "identity": ident.to_dict()}))
                return 0
            where = f", site {ident.site}" if ident.site else ""
            print(f"token {ident.token_id} ({ident.role}{where}), expires {_utc(ident.expires_at)}; "
                  f"the secret is shown only now:", file=sys.stderr)
            print(secret)
            return 0
        if args.token == "list":
            rows = book.list()
            if args.json:
                print(json.dumps(rows))
                return 0
            for r in rows:
                state = "active" if r["active"] else ("revoked" if r["revoked_at"] else "expired")
                print(f"{r['token_id']}  {r['role']:12s} {r['site'] or '-':12s} {state:8s} "
                      f"expires {_utc(r['expires_at']):20s} {r['label']}"
                      + ("" if r["persistent"] else "  (environment, not stored)"))
            return 0
        if args.token == "revoke":
            if not book.revoke(args.token_id):
                print(f"viestac token revoke: no active token {args.token_id}", file=sys.stderr)
                return 1
            print(f"revoked {args.token_id}")
            return 0
        if args.token == "login-link":
            code = book.create_code("login", role="admin", ttl_s=3600.0, created_by="cli")
            print(f"{args.url.rstrip('/')}/console.html#login={code}")
            print("single use, valid 1 hour: it signs in as admin", file=sys.stderr)
            return 0
    finally:
        store.close()
    raise AssertionError(args.token)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="viestac", description="ViESTac tactile evaluation server")
    sub = parser.add_subparsers(dest="command", required=True)

    serve = sub.add_parser("serve", help="run the server with a simulated rig (no hardware needed)")
    serve.add_argument("--host", default="127.0.0.1")
    serve.add_argument("--port", type=int, default=8000, help="0 picks a free port (printed)")
    serve.add_argument("--scenario", default=None,
                       help="the scenario to run (default: free-v1 with --scene, else contact-angle; docs/scenarios.md)")
    serve.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                       help="a scenario parameter, e.g. --param period_us=3000 (repeatable; GET /api/scenarios lists them)")
    serve.add_argument("--force", action="store_true",
                       help="run the scenario even when no device can show its tactile dimension")
    serve.add_argument("--scene", default=None,
                       help="a scene JSON file (docs/protocol.md): free-v1 explores it; with --scenario, that scenario "
                            "starts on it instead of its own scene")
    serve.add_argument("--state-hz", type=float, default=STATE_HZ)
    serve.add_argument("--gate-band", type=float, default=gate_defaults.BAND,
                       help=f"contact hysteresis band in scene units (default {gate_defaults.BAND})")
    serve.add_argument("--gate-dwell-ms", type=float, default=gate_defaults.MIN_DWELL_S * 1000.0,
                       help=f"minimum on/off time of the debounced contact (default {gate_defaults.MIN_DWELL_S * 1000:g} ms)")
    serve.add_argument("--no-realtime", action="store_true", help="do not ask for SCHED_FIFO for the loop")
    serve.add_argument("--loop-cpu", choices=MODES, default="auto",
                       help="own: the other server processes keep off the loop's CPU; shared: they may run there; "
                            f"auto (default): own with {OWN_FROM_CPUS} or more CPUs, shared below (docs/performance.md)")
    serve.add_argument("--device", action="append", default=[], metavar="[NAME=]MODEL@PORT",
                       help="a tactile device, e.g. ferrovibe@/dev/ttyUSB0 or left=fingertac@usb:303a:1001 "
                            "(repeatable; replaces the simulated rig)")
    serve.add_argument("--devices", metavar="FILE", help="a TOML file of [[device]] tables (docs/devices.md)")
    serve.add_argument("--no-rig", action="store_true", help="no simulated rig (emulated devices)")
    serve.add_argument("--finger", action="append", default=[], metavar="NAME=POINT",
                       help="the tracked point device NAME sits on, e.g. --finger ferrovibe=right.index.tip --finger "
                            "fingertac=right.thumb.tip: each device gets the cues of its finger's tool only "
                            "(repeatable; default the primary point right.index.tip; docs/devices.md)")
    serve.add_argument("--rig", default="fingertac,ferrovibe", metavar="MODEL[,MODEL...]",
                       help="the simulated rig's emulated devices (default fingertac,ferrovibe; devkit adds "
                            "temperature and friction; audio a voice-coil tactor on a JACK dummy server)")
    serve.add_argument("--data-dir", default=os.environ.get("VIESTAC_DATA", "data"),
                       help="where the experiment database lives (default: $VIESTAC_DATA or ./data)")
    serve.add_argument("--studies", default=str(STUDIES_DIR), help="the directory of study files (*.toml)")
    serve.add_argument("--record-every", type=int, default=10, metavar="N",
                       help="trajectory rows every Nth tick during a trial (default 10 = 100 Hz; 1 = every tick)")
    serve.add_argument("--tracker-udp", default="auto", metavar="HOST:PORT|PORT|auto|off",
                       help="the UDP port the 1 kHz loop reads tracker samples from, the shortest tracker -> device "
                            "path (docs/protocol.md); auto = the HTTP host and port + 1 (a free one with --port 0)")
    serve.add_argument("--tracker", action="append", default=[], metavar="SPEC",
                       help="a tracker source, repeatable: leap[:URL], replay:FILE.csv[:loop|:once], scripted:NAME "
                            "(tap, circle, pinch); run by the tracker host, sent to the tracker UDP port "
                            "(docs/trackers.md)")
    serve.add_argument("--overrun-threshold", type=int, default=10, metavar="N",
                       help="/api/health is degraded above N loop overruns (periods > 1.5 ms) in 10 s (default 10)")
    serve.add_argument("--lease-ttl", type=float, default=60.0, metavar="SECONDS",
                       help="the control lease goes to the next in the queue when its holder has not renewed it for "
                            "this long (default 60)")
    serve.add_argument("--tls-cert", metavar="PEM", help="serve HTTPS and WSS with this certificate (viestac tls init)")
    serve.add_argument("--tls-key", metavar="PEM", help="the certificate's private key")
    serve.add_argument("--allow-host", action="append", default=[], metavar="NAME",
                       help="also answer requests for this Host name (besides loopback, the bound address, this "
                            "machine's names and the certificate's; '*.example.org' a domain; '*' any: behind a proxy)")
    serve.add_argument("--allow-origin", action="append", default=[], metavar="http(s)://HOST[:PORT]",
                       help="also let pages of this origin use the API and /ws (CORS for it, nothing else)")
    serve.add_argument("--no-login-link", action="store_true", help="do not print a single-use admin login link")
    serve.add_argument("--log-level", default="info", choices=["critical", "error", "warning", "info", "debug"])
    serve.set_defaults(func=_serve)

    tls_parser = sub.add_parser("tls", help="certificates for HTTPS/WSS on the LAN (a headset needs it for WebXR)")
    tls_sub = tls_parser.add_subparsers(dest="tls_command", required=True)
    tls_init = tls_sub.add_parser("init", help="make a local CA (once) and a server certificate for this machine's "
                                               "names and IP addresses")
    tls_init.add_argument("--data-dir", default=os.environ.get("VIESTAC_DATA", "data"),
                          help="the files go to DATA_DIR/tls unless --dir says otherwise")
    tls_init.add_argument("--dir", help="where ca.pem, ca.key, server.pem and server.key go")
    tls_init.add_argument("--name", action="append", default=[], help="another DNS name for the certificate")
    tls_init.add_argument("--ip", action="append", default=[], help="another IP address for the certificate")
    tls_init.add_argument("--no-defaults", action="store_true",
                          help="only --name/--ip (default: also localhost, this machine's names and addresses)")
    tls_init.add_argument("--new-ca", action="store_true", help="replace the CA (every headset must trust it again)")
    tls_init.set_defaults(func=_tls)

    devices = sub.add_parser("devices", help="list serial ports, configured devices and a running server's devices")
    devices.add_argument("--devices", metavar="FILE", help="also check the devices of this TOML file")
    devices.add_argument("--server", default="http://127.0.0.1:8000", help="a running server to ask for status")
    devices.add_argument("--token", default=os.environ.get("VIESTAC_TOKEN"),
                         help="the server's access token (default $VIESTAC_TOKEN; `viestac token create`)")
    devices.add_argument("--json", action="store_true")
    devices.set_defaults(func=_devices)

    emulate = sub.add_parser("emulate", help="emulate fingertac|ferrovibe|devkit on a pseudo-terminal",
                             add_help=False)
    emulate.add_argument("rest", nargs=argparse.REMAINDER)
    emulate.set_defaults(func=_emulate)

    render = sub.add_parser("render", help="run a recorded HIP trajectory through a scene (virtual clock)")
    render.add_argument("--scene", required=True, help="a scenario name (e.g. contact-angle) or a scene JSON file")
    render.add_argument("--trajectory", required=True,
                        help="CSV with columns t,x,y,z, or t and NAME.x,NAME.y,NAME.z per tracked point (what "
                             "export writes for several fingers)")
    render.add_argument("--tool", action="append", default=[], metavar="POINT",
                        help="also simulate this tracked point as a tool (e.g. right.thumb.tip; repeatable); "
                             "the primary point and the scenario's fingers always are")
    render.add_argument("--out", required=True, help="output CSV, one row per tick")
    render.set_defaults(func=_render)

    exp = sub.add_parser("export", help="write sessions as CSV (wide, long, trajectories) and JSON (docs/data.md)")
    exp.add_argument("session", nargs="?", metavar="SESSION_ID", help="the session to export (GET /api/sessions)")
    exp.add_argument("--all", action="store_true", help="every session, plus all_trials_wide.csv")
    exp.add_argument("--out", required=True, metavar="DIR", help="one folder per session goes here")
    exp.add_argument("--data-dir", default=os.environ.get("VIESTAC_DATA", "data"),
                     help="where the experiment database lives (default: $VIESTAC_DATA or ./data)")
    exp.add_argument("--force", action="store_true", help="replace a different earlier export in DIR")
    exp.add_argument("--site", metavar="SITE", help="only the sessions of this lab (site); another lab's are unknown")
    exp.set_defaults(func=_export)

    ana = sub.add_parser("analyze", help="the thesis's statistics of a study's sessions: report.html, stats.json, "
                                         "figures (docs/analysis.md)")
    ana.add_argument("data", metavar="DATA", help="a data directory (serve --data-dir) or its viestac.sqlite file")
    ana.add_argument("--out", required=True, metavar="DIR", help="where report.html, stats.json and figures/ go")
    ana.add_argument("--study", metavar="ID", help="the study to analyse (needed when DATA holds several)")
    ana.add_argument("--workers", type=int, metavar="N", help="processes drawing the figures (default: the usable "
                                                              "CPUs); the files are the same whatever N")
    ana.set_defaults(func=_analyze)

    report = sub.add_parser("report", help="reports across studies (docs/report-card.md)")
    kinds = report.add_subparsers(dest="kind", required=True)
    card = kinds.add_parser("devices", help="the device report card of the battery studies in DATA: "
                                            "report-card.html, stats.json")
    card.add_argument("data", metavar="DATA", nargs="+", help="data directories (serve --data-dir) or viestac.sqlite "
                                                              "files holding battery studies (battery-<model>)")
    card.add_argument("--out", required=True, metavar="DIR", help="where report-card.html and stats.json go")
    card.add_argument("--rig", metavar="FILE", help="a rig file whose audio channel's calibration gives physical units")
    card.set_defaults(func=_report_devices)

    battery = sub.add_parser("battery", help="the device battery as a study file for one device: every part the "
                                             "device can show, the rest listed as skipped with why (docs/battery.md)")
    battery.add_argument("--device", metavar="MODEL", help="a built-in or audio device model (required unless "
                                                           "--trial-counts)")
    battery.add_argument("--out", metavar="FILE", help="the study file to write (required unless --trial-counts)")
    battery.add_argument("--trials", action="append", metavar="PART=N", help="a part's main trials instead of the "
                         "power analysis's default (repeatable)")
    battery.add_argument("--target-se", action="append", metavar="PART=VALUE", help="a part's trial count from the "
                         "power analysis for this per-participant SE instead of the part's own target (repeatable)")
    battery.add_argument("--trial-counts", action="store_true", help="print the power analysis behind the trial "
                         "counts (per-participant SE of every part against its trials) and exit")
    battery.add_argument("--observers", type=int, default=500, metavar="N", help="synthetic observers of the power "
                         "analysis (default 500)")
    battery.add_argument("--seed", type=int, default=38, metavar="S", help="the power analysis's seed (default 38)")
    battery.add_argument("--add", dest="add_parts", metavar="FILE", help="a TOML file of [[tasks]] tables: a lab's own parts, "
                         "appended and counterbalanced with the rest")
    battery.add_argument("--participants", type=int, default=12, metavar="N")
    battery.set_defaults(func=_battery)

    study = sub.add_parser("study", help="run a study file with synthetic participants on the virtual clock "
                                         "(--simulate), then the analysis")
    study.add_argument("--simulate", action="store_true", help="synthetic participants, simulated rig, virtual clock")
    study.add_argument("--power", action="store_true", help="power analysis: many simulated studies per number of "
                       "participants on Dask, power of every analysis against N (docs/power.md)")
    study.add_argument("--study", default=str(STUDIES_DIR / "thesis-2021.toml"), help="the study file")
    study.add_argument("--participants", default="13", metavar="N[,N...]",
                       help="participants (--power: the grid, e.g. 8,12,16,24,32)")
    study.add_argument("--replications", type=int, default=100, metavar="K",
                       help="--power: simulated studies per N (default 100)")
    study.add_argument("--seed", type=int, default=2021)
    study.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                       help="an effect setting of the synthetic participants, e.g. estimation.b=0.9 or "
                            "agent.ferrovibe.duration_scale=1.3 (docs/synthetic.md, \"Effect settings\")")
    study.add_argument("--alpha", type=float, default=0.05, help="--power: significance level (default 0.05)")
    study.add_argument("--trials", metavar="T[,T...]", help="--power on a psychophysics study: the trial counts "
                       "(default: 1/4, 1/2, 3/4 and all of max_trials; docs/power.md)")
    study.add_argument("--target-se-db", type=float, metavar="DB",
                       help="--power on a psychophysics study: the threshold standard error to reach (default 1 dB)")
    study.add_argument("--workers", type=int, help="--power: local Dask worker processes; --simulate: processes "
                       "the participants run in, same data whatever the number (default: one per core)")
    study.add_argument("--scheduler", metavar="ADDRESS",
                       help="--power: a Dask scheduler (tcp://host:8786) to run on instead of a local cluster")
    study.add_argument("--out", required=True, metavar="DIR",
                       help="data/ and report/ go here (must be new); --power: the results (a rerun resumes)")
    study.add_argument("--no-analysis", action="store_true", help="only simulate")
    study.add_argument("--quiet", action="store_true", help="no progress bar")
    study.set_defaults(func=_study)

    data_default = os.environ.get("VIESTAC_DATA", "data")
    token = sub.add_parser("token", help="access tokens (roles admin, experimenter, participant, observer)")
    token_sub = token.add_subparsers(dest="token", required=True)
    t_create = token_sub.add_parser("create", help="a new token; prints its secret once")
    t_create.add_argument("--role", required=True, choices=("admin", "experimenter", "participant", "observer"))
    t_create.add_argument("--site", default=None, help="the lab an experimenter (or participant) belongs to")
    t_create.add_argument("--session", default=None, help="the session a participant token is bound to")
    t_create.add_argument("--label", default="", help="who holds it (shown in lists, the lease and the audit log)")
    t_create.add_argument("--ttl", default="30d", help="lifetime: 30d, 12h, 45m, or none (default 30d)")
    t_create.add_argument("--json", action="store_true", help="print {token, identity}")
    t_list = token_sub.add_parser("list", help="every token (no secrets): active, revoked, expired")
    t_list.add_argument("--json", action="store_true")
    t_revoke = token_sub.add_parser("revoke", help="revoke a token by its id (a running server refuses it at once)")
    t_revoke.add_argument("token_id", metavar="ID")
    t_link = token_sub.add_parser("login-link", help="a fresh single-use admin login link (valid 1 hour)")
    t_link.add_argument("--url", default="http://127.0.0.1:8000", help="the server's address")
    for p in (t_create, t_list, t_revoke, t_link):
        p.add_argument("--data-dir", default=data_default,
                       help="where access.sqlite and access.key live (default: $VIESTAC_DATA or ./data)")
    token.set_defaults(func=_token)

    bench = sub.add_parser("bench", help="benchmarks")
    bench.set_defaults(extra="bench")  # every bench, checked in main before it starts
    bench_sub = bench.add_subparsers(dest="bench", required=True)
    loop = bench_sub.add_parser("loop", help="loop timing with N viewers at 60 Hz and tracker clients at 120 Hz")
    loop.add_argument("--seconds", type=float, default=10.0)
    loop.add_argument("--clients", type=int, default=8, help="viewer clients")
    loop.add_argument("--trackers", type=int, default=2)
    loop.add_argument("--warmup", type=float, default=3.0)
    loop.add_argument("--scenario", default="contact-angle")
    loop.add_argument("--kernel-trace", action="store_true",
                      help="also trace the loop's wake-ups with the kernel's tracer (root, tracefs) and say what "
                           "made late ones late: the timer interrupt or the scheduling")
    loop.add_argument("--loop-cpu", choices=MODES, default="auto",
                      help="the server's --loop-cpu; with own the load generator also keeps off the loop's CPU")
    loop.add_argument("--floor-seconds", type=float, default=3.0,
                      help="first measure the machine's floor under a tick for this long per pattern (the "
                           "baseline of the same run, as `viestac bench floor`); 0: skip it")
    loop.add_argument("--json", action="store_true", help="print one JSON object")
    loop.set_defaults(func=_bench_loop)
    floor = bench_sub.add_parser("floor", help="what a tick costs on this machine before any work of its own: an "
                                               "idle tick, and one that wakes two processes on other CPUs "
                                               "(the loop's CPU, priority and sleep)")
    floor.add_argument("--seconds", type=float, default=3.0, help="per pattern (1000 ticks a second)")
    floor.add_argument("--loop-cpu", choices=MODES, default="auto", help="the CPU plan, as `viestac serve --loop-cpu`")
    floor.add_argument("--publish-every", type=int, default=None,
                       help="the sending pattern sends on every Nth tick (default 6: the loop bench's share)")
    floor.add_argument("--json", action="store_true", help="print one JSON object")
    floor.set_defaults(func=_bench_floor)
    link = bench_sub.add_parser("link", help="a cue changing every tick through pyserial to an emulated FerroVibe: "
                                             "link share and latency of the newest value")
    link.add_argument("--seconds", type=float, default=10.0)
    link.add_argument("--rate", type=float, default=1000.0, help="cue changes per second (default: every 1 kHz tick)")
    link.add_argument("--share", type=float, default=0.5, help="the host's share of the link (default 0.5)")
    link.add_argument("--json", action="store_true", help="print one JSON object")
    link.set_defaults(func=_bench_link)
    audio = bench_sub.add_parser("audio", help="an audio tactor under a JACK dummy server: cue -> first sample of "
                                               "the new waveform at the output port, per block size")
    audio.add_argument("--block", type=int, action="append", default=None, metavar="FRAMES",
                       help="block sizes (repeatable; default 32 64 128 256)")
    audio.add_argument("--cues", type=int, default=1000, help="cues per block size (default 1000)")
    audio.add_argument("--no-realtime", action="store_true",
                       help="jackd without real-time priority (default: with it when allowed)")
    audio.add_argument("--json", action="store_true", help="print one JSON object")
    audio.set_defaults(func=_bench_audio, block=None)
    latency = bench_sub.add_parser("latency", help="tracker message sent -> device command written on an emulated "
                                                   "FerroVibe's pty, with N viewers at 60 Hz")
    latency.add_argument("--seconds", type=float, default=None,
                         help="the window (default: long enough for --samples, ~92 s for 1000)")
    latency.add_argument("--samples", type=int, default=1000,
                         help="switches to measure (default 1000: a p99 from ~100 would be their maximum)")
    latency.add_argument("--clients", type=int, default=0, help="viewer clients (default 0)")
    latency.add_argument("--warmup", type=float, default=3.0)
    latency.add_argument("--tracker", choices=("udp", "ws"), default="udp",
                         help="udp: a tracker bridge sending to the loop's tracker UDP port (default); "
                              "ws: a browser-style tracker on /ws, through the hub")
    latency.add_argument("--json", action="store_true", help="print one JSON object")
    latency.set_defaults(func=_bench_latency)
    roundtrip = bench_sub.add_parser("roundtrip", help="a browser-style participant on /ws: tracker sample sent -> "
                                                       "the first state frame showing it, with N viewers")
    roundtrip.add_argument("--seconds", type=float, default=20.0,
                           help="measured seconds per path (default 20: 1200 samples at 60 Hz)")
    roundtrip.add_argument("--clients", type=int, default=0, help="viewer clients (default 0)")
    roundtrip.add_argument("--format", choices=("msgpack", "json"), default="msgpack",
                           help="the encoding of the participant and the viewers")
    roundtrip.add_argument("--where", choices=("free", "contact", "both"), default="both",
                           help="free: the HIP away from every object (frames on the 60 Hz cadence); contact: "
                                "pressed into the dome, the tilt cue changes with every sample (a frame at once)")
    roundtrip.add_argument("--rate", type=float, default=60.0, help="tracker samples per second (default 60)")
    roundtrip.add_argument("--warmup", type=float, default=3.0)
    roundtrip.add_argument("--join", choices=("last", "first"), default="last",
                           help="the participant joins after the viewers (default) or before them; the hub serves "
                                "participants first either way")
    roundtrip.add_argument("--json", action="store_true", help="print one JSON object")
    roundtrip.set_defaults(func=_bench_roundtrip)
    switch = bench_sub.add_parser("switch", help="a burst of scenario switches (the largest scenes) against the "
                                                 "loop's deadlines: overruns, period p99/max, tick cost max")
    switch.add_argument("--switches", type=int, default=100)
    switch.add_argument("--every-ms", type=float, default=24.0, help="spacing of the switches (default 24 ms)")
    switch.add_argument("--start", default="contact-angle", help="the scenario the server starts with")
    switch.add_argument("--json", action="store_true", help="print one JSON object")
    switch.set_defaults(func=_bench_switch)
    xr = bench_sub.add_parser("xr", help="the WebXR client in an emulated headset (iwer, headless Chromium): session "
                                         "frame rate, hand pose -> proxy drawn, hand pose -> device command, "
                                         "tactile leads picture (docs/xr.md)")
    xr.add_argument("--touches", type=int, default=20, help="fingertip jumps onto the dome (default 20)")
    xr.add_argument("--seconds", type=float, default=5.0, help="frame-rate window (default 5 s)")
    xr.add_argument("--json", action="store_true", help="print one JSON object")
    xr.set_defaults(func=_bench_xr)
    faults = bench_sub.add_parser("faults", help="kill -9 of each process, device unplug, tracker loss, floods, huge "
                                                 "and non-finite values, bad frames, slow readers: recovery times, "
                                                 "overruns, frames and samples lost (docs/reliability.md)")
    faults.add_argument("--repeat", type=int, default=3, help="repetitions of each fault (default 3)")
    faults.add_argument("--only", default="", metavar="FAULT[,FAULT...]", help="only these faults (default all: "
                        "loop_kill, device_host_kill, emulator_restart, device_unplug, tracker_loss, key_flood, "
                        "tracker_flood, tracker_jitter, slow_readers, bad_frames, huge_values_ws, huge_values_udp)")
    faults.add_argument("--keep", metavar="DIR", help="keep the run's database, study and actuator timelines in "
                        "this new directory")
    faults.add_argument("--check", action="store_true", help="exit 1 when a fault misses its acceptance")
    faults.add_argument("--load", type=int, default=0, metavar="N", help="run the bench twice: on the machine as "
                        "it is, then with N CPU hogs beside the server (a busy lab PC); report both")
    faults.add_argument("--json", action="store_true", help="print one JSON object")
    faults.set_defaults(func=_bench_faults)
    psy = bench_sub.add_parser("psychophysics", help="staircase convergence, QUEST+ against 1-up/3-down, QUEST+ "
                                                     "choice time, bootstrap coverage, information-transfer bias "
                                                     "(docs/psychophysics.md)")
    psy.add_argument("--quick", action="store_true", help="a tenth of the runs (well under a minute)")
    psy.add_argument("--json", action="store_true", help="print one JSON object")
    psy.set_defaults(func=_bench_psychophysics)
    intervals = bench_sub.add_parser("intervals", help="stimulus-v1's intervals on an emulated FingerTac's timeline: "
                                                       "onset and duration error against the plan "
                                                       "(docs/performance.md \"Psychophysics intervals\")")
    intervals.add_argument("--intervals", type=int, default=1000, help="intervals to measure (default 1000, ~2 min)")
    intervals.add_argument("--quick", action="store_true", help="200 intervals (about half a minute)")
    intervals.add_argument("--loop-cpu", choices=MODES, default="auto", help="the server's --loop-cpu (default auto)")
    intervals.add_argument("--json", action="store_true", help="print one JSON object")
    intervals.set_defaults(func=_bench_intervals)
    tracking = bench_sub.add_parser("tracking", help="tracker filters: jitter against lag and contact chatter on "
                                    "noisy finger paths (raw, 1€, moving average; chart), and Leap sample -> device "
                                    "command through the whole server")
    tracking.add_argument("--out", required=True, metavar="DIR", help="tracking.json and tracking_filters.png go here")
    tracking.add_argument("--latency-seconds", type=float, default=130.0,
                          help="how long to measure Leap sample -> device command (default 130 s: > 1000 "
                               "switches; 0 skips it)")
    tracking.add_argument("--viewers", type=int, default=64, help="viewer clients during the latency part")
    tracking.add_argument("--json", action="store_true", help="print one JSON object on one line")
    tracking.set_defaults(func=_bench_tracking)
    for name, func, what in (("accuracy", _bench_accuracy, "cost against error of every contact method on fixed "
                                                           "trajectories over the thesis scenes"),
                             ("stability", _bench_stability, "where each method fails: speed x thickness, stiffness "
                                                             "x loop rate, tracker noise x hysteresis"),
                             ("objects", _bench_objects, "the god-object's cost per tick against the number of "
                                                         "objects (1 to 1000 primitives) and tools (1 to 10 fingertips)")):
        sweep = bench_sub.add_parser(name, help=f"{what} (JSON + charts)")
        sweep.add_argument("--out", required=True, metavar="DIR", help=f"{name}.json and the charts go here")
        sweep.add_argument("--quick", action="store_true", help="a reduced grid (well under 2 min)")
        sweep.add_argument("--json", action="store_true", help="print the summary as one JSON object")
        sweep.set_defaults(func=func)
    return parser


def main(argv: list[str] | None = None) -> int:
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(levelname)s %(message)s")
    limit_repeats()  # a line that keeps coming: the first at once, then a count (server/log_repeats.py)
    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    if unknown:  # argparse.REMAINDER leaves an option it starts with (`emulate --help`) to the extras
        if args.command != "emulate":
            parser.error(f"unrecognized arguments: {' '.join(unknown)}")
        args.rest = unknown + args.rest
    if getattr(args, "extra", None) and _without_extra(f"viestac {args.command}", args.extra):
        return 2
    try:
        return args.func(args)
    except (UnknownScenario, SceneError, ValueError) as exc:
        print(f"viestac: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
