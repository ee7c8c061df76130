"""The loop process: a thin adapter that runs Loop at 1 kHz on a real clock.

Why a separate process at SCHED_FIFO (docs/architecture.md "Processes, and why the loop has its own"):
a 1 kHz thread beside the asyncio server shares the GIL with the broadcasts and misses
deadlines (period p99 2-5 ms from 8 viewers on); a separate process at real-time priority held
p99 1.03 ms with 64 viewers. Without CAP_SYS_NICE/root it falls back to normal priority with a
clear warning, reported in telemetry as `rt: false`.

It owns the clock, the deadline scheduler and the sockets; the tick itself (records in, the
simulation step, fail-safe, what goes out) is Loop.tick (core.py). No serial port, no socket
to a client, no thread (the device drivers live in the device host process). It talks only through
non-blocking sockets (server/ipc): the mailbox to the hub, and the cue channel that carries a tick's
changed cues to the device host's feed thread before the tick's state record leaves. It also reads the
tracker UDP port (tracker_udp.py, bound by the hub) at the start of every tick. It exits when the
hub goes away.
Run as `python -m server.loop.process --fd N --cues-fd C --doorbell M --config JSON` by the hub
(server/hub/supervisor.py).
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import socket
from collections import deque
import sys
from dataclasses import asdict, dataclass, field

from devices.feed import CUE_HEARTBEAT_MS
from scenarios import registry
from scenarios.free import ID as FREE_SCENARIO
from server.core.haptics.contact_gate import BAND, MIN_DWELL_S, ContactGate
from server import ipc
from server.ipc.records import TO_LOOP, Alive, Cues, Hello, Log, Record, Stop, Trial
from server.cpu_plan import pin_process
from server.loop.builder import SwitchBuilder
from server.loop.cadence import STATE_HZ
from server.loop.clock import Clock, MonotonicClock
from server.loop.tick import Loop
from server.loop.scheduler import DeadlineScheduler
from server.loop.simulation import Simulation
from server.loop.tracker_udp import TrackerPort
from server.core.scene import Scene

MAX_BACKLOG = 10_000  # records waiting for the hub (~5 MB); beyond that the oldest go, with a log line


@dataclass(frozen=True)
class LoopConfig:
    scenario: str = registry.DEFAULT_SCENARIO
    scenario_params: dict = field(default_factory=dict)
    trial: dict | None = None  # a free trial ({"phase", "params", "index"}) restored after a restart
    start_tick: int = 0  # a restarted loop continues the dead one's clock (server/hub/supervisor.py)
    start_frame: int = 0
    scene_file: str | None = None  # a custom scene (docs/protocol.md format) instead of the scenario's
    # The scenario the scene file was given for (serve --scenario X --scene F): a loop restarted into
    # another one (server/hub/supervisor.py) builds that one's own scene; free-v1 always explores the file.
    scene_for: str | None = None
    tick_hz: int = 1000
    state_hz: float = STATE_HZ
    realtime: bool = True
    rt_priority: int = 50
    cpu: int | None = None  # the CPU the loop pins itself to, so its caches stay warm between ticks (server/cpu_plan.py)
    gate_band: float = BAND
    gate_min_on_s: float = MIN_DWELL_S
    gate_min_off_s: float = MIN_DWELL_S
    seed: int = 0
    rig: tuple[str, ...] = ()  # the rig's fingers besides the primary point: one tool each (Simulation)

    def to_json(self) -> str:
        return json.dumps(asdict(self))

    @classmethod
    def from_json(cls, text: str) -> LoopConfig:
        fields = json.loads(text)
        fields["rig"] = tuple(fields.get("rig", ()))
        return cls(**fields)


def build_core(config: LoopConfig) -> Loop:
    scene = Scene.load(config.scene_file) if config.scene_file else None

    def make_sim(scenario, seed: int, given: Scene | None = None) -> Simulation:
        gate = ContactGate(config.gate_band, config.gate_min_on_s, config.gate_min_off_s)
        if given is None and scenario.id == FREE_SCENARIO:  # free-v1 explores the scene file, after a switch too
            given = scene
        return Simulation(scenario, tick_hz=config.tick_hz, gate=gate, seed=seed, scene=given, rig=config.rig)

    scenario = registry.create(config.scenario, **config.scenario_params)
    given_for = config.scene_for is None or registry.resolve(config.scene_for).id == scenario.id
    core = Loop(make_sim(scenario, config.seed, scene if given_for else None), state_hz=config.state_hz, make_sim=make_sim,
                    build_off_tick=True)  # switches are built by SwitchBuilder, never inside a tick
    core.params, core.seed = dict(config.scenario_params), config.seed
    core.sim.data.tick, core.frames = config.start_tick, config.start_frame
    if config.trial is not None:
        core.apply(Trial(config.trial), 0)
        core.outbox.clear()  # announced with the scene at start
    return core


def try_realtime(priority: int) -> str | None:
    """Switch this process to SCHED_FIFO; return a warning when that is not allowed."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
        return None
    except (PermissionError, OSError, AttributeError) as exc:
        return (f"loop runs WITHOUT real-time priority ({exc}); expect period p99 around 2 ms and "
                "missed deadlines under load. Run as root or grant CAP_SYS_NICE (e.g. "
                "`setcap cap_sys_nice+ep` on the python binary, or an rtprio limit) for 1 kHz.")


def pin_to(cpu: int | None) -> str | None:
    """Pin every thread of this process (and the builder thread started after) to `cpu`; a
    warning when that is not allowed (a cpuset without that CPU), and the loop runs unpinned."""
    if cpu is None:
        return None
    try:
        pin_process({cpu})
        return None
    except OSError as exc:
        return f"loop not pinned to CPU {cpu} ({exc}); its caches are colder after other processes ran"


def run(sock: socket.socket, config: LoopConfig, clock: Clock | None = None,
        doorbell: ipc.Doorbell | None = None, cue_sock: socket.socket | None = None,
        tracker_port: TrackerPort | None = None) -> None:
    clock = clock or MonotonicClock()
    core = build_core(config)
    rt_warning = try_realtime(config.rt_priority) if config.realtime else "real-time priority disabled by configuration"
    rt = rt_warning is None
    cpu_warning = pin_to(config.cpu)
    builder = SwitchBuilder(core)
    builder.warm_up()
    parent = os.getppid()
    ipc.send_record(sock, Hello({"pid": os.getpid(), "rt": rt, "tick_hz": config.tick_hz,
                                 "state_hz": config.state_hz, "scenario": core.sim.scenario.id,
                                 "cpu": config.cpu if cpu_warning is None else None}))
    for warning in (rt_warning, cpu_warning):
        if warning:
            ipc.send_record(sock, Log("warning", warning))
    for record in core.announce():
        ipc.send_record(sock, record)
    # Everything built so far lives for the whole run: keep it out of the collector's sight so
    # a collection never walks it inside a tick.
    gc.collect()
    gc.freeze()
    scheduler = DeadlineScheduler(clock, 1_000_000_000 // config.tick_hz)
    backlog: deque[Record] = deque()  # records for the hub not sent yet (its end was full), in order
    cue_sent_ns = 0  # the last record on the cue channel (the heartbeat below)
    owed = 0  # records the hub rang the doorbell for that this loop has not read yet
    while True:
        start, period = scheduler.wait_next()
        try:
            if doorbell is None:
                records = ipc.drain(sock, TO_LOOP)
            else:
                owed += doorbell.rings()
                records = ()
                if owed:
                    asked = min(owed, ipc.DRAIN_LIMIT)
                    records = ipc.drain(sock, TO_LOOP, asked)
                    owed = owed - asked if len(records) == asked else 0  # fewer: the count was ahead of the socket
        except ipc.PeerClosed:
            return
        if records and any(type(record) is Stop for record in records):
            return
        if tracker_port is not None:  # after the mailbox: a UDP sample read now is the newest
            samples = tracker_port.drain(start)
            if samples:
                records = [*records, *samples]
            if tracker_port.notices:
                for text in tracker_port.notices:
                    ipc.send_record(sock, Log("warning", text))
                tracker_port.notices.clear()
        core.resyncs = scheduler.resyncs
        out = core.tick(records, start)
        if out.records or out.faults or backlog:  # announcements, logs, fault / recovered (the hub's health)
            backlog.extend(out.records)
            backlog.extend(out.faults)
            _send_in_order(sock, backlog)
        if out.cues is not None and cue_sock is not None:  # first: the device command leaves before the frame
            try:
                # with several tools, `fingers` carries the other fingers' cues (devices/feed.py)
                if not ipc.send_record(cue_sock, Cues(out.tick, clock.now_ns(), out.cues, out.finger_cues)):
                    core.resend_device_cues()  # the feed is behind: try again next tick (latest wins)
            except OSError as exc:  # the device host's end is gone for good: nobody drives the devices now
                cue_sock = None
                ipc.send_record(sock, Log("error", f"cue channel closed ({exc}); device cues stop"))
        if cue_sock is not None:  # heartbeat: the device host turns every actuator off when this goes quiet
            if out.cues is not None:
                cue_sent_ns = start
            elif start - cue_sent_ns >= CUE_HEARTBEAT_MS * 1_000_000:
                try:
                    if ipc.send_record(cue_sock, Alive(out.tick, clock.now_ns())):
                        cue_sent_ns = start
                except OSError:
                    pass  # the next cue send finds the channel gone and says so
        if out.state is not None:
            if backlog or not ipc.send_record(sock, out.state):
                core.unsent(out.state)  # the hub is behind: its rows and events ride with the next one
        core.record_sample(period, clock.now_ns() - start, out.state is not None)
        if core.pending_switch is not None or builder.busy:
            builder.between_ticks()  # off the tick: install a built switch, build the next
        if core.sim.data.tick % 1000 == 0 and os.getppid() != parent:
            return  # the hub died without closing the mailbox


def _send_in_order(sock: socket.socket, backlog: deque) -> None:
    """Send the waiting records, oldest first, until the mailbox is full; the rest wait for the
    next tick. A scene announcement or a trial's end must not be lost because the hub was busy."""
    while backlog and ipc.send_record(sock, backlog[0]):
        backlog.popleft()
    if len(backlog) > MAX_BACKLOG:  # the hub has not read for seconds: keep the newest, say so
        lost = len(backlog) - MAX_BACKLOG
        for _ in range(lost):
            backlog.popleft()
        backlog.append(Log("error", f"the hub did not read the loop's records: {lost} dropped"))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="viestac-loop")
    parser.add_argument("--fd", type=int, required=True)
    parser.add_argument("--config", required=True)
    parser.add_argument("--doorbell", type=int, default=None, help="memfd of the mailbox doorbell")
    parser.add_argument("--cues-fd", type=int, default=None, help="the cue channel to the device host's feed")
    parser.add_argument("--tracker-fd", type=int, default=None, help="the tracker UDP socket (bound by the hub)")
    args = parser.parse_args(argv)
    sock = socket.socket(fileno=args.fd)
    sock.setblocking(False)
    try:
        doorbell = ipc.Doorbell(args.doorbell) if args.doorbell is not None else None
        cue_sock = None
        if args.cues_fd is not None:
            cue_sock = socket.socket(fileno=args.cues_fd)
            cue_sock.setblocking(False)
        tracker_port = None
        if args.tracker_fd is not None:
            tracker_port = TrackerPort(socket.socket(fileno=args.tracker_fd))
        run(sock, LoopConfig.from_json(args.config), doorbell=doorbell, cue_sock=cue_sock, tracker_port=tracker_port)
    except KeyboardInterrupt:
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
