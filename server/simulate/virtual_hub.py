"""The hub's, the loop process's and the device host's roles for a simulated study, in one
process on the virtual clock.

It drives the real loop core (Loop.tick: the same tick as `viestac serve`, fail-safe
included), checks the experiment engine's requests with the hub's own scenario control
(server/hub/control.py) and applies them between ticks exactly as the loop applies mailbox
records, hands every record to the listeners (the recorder), and feeds the virtual devices from
the tick's cue output as the device host's feed does (wire form decoded, only when it changed).
Nothing sleeps and nothing reads a clock: `advance()` runs ticks as fast as the machine can, so a
study takes as long as its computation, not as long as its trials.

It offers what the engine needs of a hub (server/experiment/engine.HubPort): switch_scenario,
set_trial, set_recording, scenario_state, scenario_target, last_state, listeners; plus set_hip and command for
the synthetic participant.
"""

from __future__ import annotations

from typing import Callable

from scenarios import registry
from server.hub.control import ScenarioControl
from server.loop.cadence import STATE_HZ
from server.ipc.records import Record, RecordEvery, ScenarioAnnounce
from server.loop.tick import Loop
from server.loop.simulation import Simulation
from server.simulate.virtual_device import VirtualDevice

TICK_NS = 1_000_000


class VirtualHub:
    def __init__(self, devices: dict[str, VirtualDevice], *, scenario: str = registry.DEFAULT_SCENARIO,
                 params: dict | None = None, seed: int = 0, tick_hz: int = 1000, state_hz: float = STATE_HZ):
        self.devices = devices
        self.tick_hz = tick_hz
        spec = registry.resolve(scenario)
        sim = Simulation(registry.create(spec.id, **(params or {})), tick_hz=tick_hz, seed=seed)
        self.core = Loop(sim, state_hz=state_hz, drawn=False)  # no viewer: the recorder and the participant read
        self.core.params, self.core.seed = registry.check_scenario_params(spec, params or {}), seed
        # which scenario runs: the hub's one owner of it (it hears the announcements in _emit)
        self.control = ScenarioControl(self._send, lambda: {n: d.profile for n, d in self.devices.items()})
        self.listeners: list[Callable[[Record], None]] = []
        self.last_state: dict | None = None  # the client view of the last state record
        self.record_every = 0
        self.last_error: str | None = None  # why the last failed tick failed (the listeners got it as a log record)
        self._emit_all(self.core.announce())
        self._settle_devices()

    # -- what the engine asks (checked as the hub checks them) ------------------------------------
    @property
    def scenario_state(self) -> dict | None:
        return self.control.state

    @property
    def scenario_target(self) -> dict | None:
        """What runs once the switches sent land: here a switch is built at once (Loop)."""
        return self.control.target()

    def switch_scenario(self, name: str, params: dict | None = None, seed: int = 0, force: bool = False) -> dict:
        return self.control.switch_scenario(name, params, seed, force)

    def set_trial(self, phase: str | None, params: dict | None = None, index: int = 0,
                  force: bool = False) -> dict | None:
        return self.control.set_trial(phase, params, index, force)

    def require_devices(self, scenario: str | None = None, force: bool = False) -> None:
        self.control.require_devices(scenario, force)

    def devices_needed(self, scenario: str | None = None) -> dict[str, tuple[str, ...]]:
        return self.control.devices_needed(scenario)

    def set_recording(self, every_n_ticks: int) -> None:
        self.record_every = every_n_ticks
        self._send(RecordEvery(every_n_ticks))

    # -- what the participant does ---------------------------------------------------------------
    def set_hip(self, position) -> None:
        self.core.sim.set_hip((float(position[0]), float(position[1]), float(position[2])))

    def command(self, key: str, action: str = "press", value=None) -> None:
        """A key or command, as the experimenter's console sends it (operator role)."""
        self.control.command(key, action, value)

    @property
    def tick(self) -> int:
        return self.core.sim.data.tick

    @property
    def t_s(self) -> float:
        return self.core.sim.data.tick / self.tick_hz

    def advance(self, ticks: int = 1) -> None:
        """Run `ticks` loop ticks; the devices follow to the end of each tick."""
        core, devices, tick_hz = self.core, tuple(self.devices.values()), self.tick_hz
        for _ in range(ticks):
            out = core.tick((), core.sim.data.tick * TICK_NS)
            if out.records:
                self._emit_all(out.records)
            if out.error is not None:
                self.last_error = out.error
            if out.cues is not None:  # what the feed hands the devices: the decoded cue record, which
                # is the tick's own cue tuple (cue_from_wire inverts cue_to_wire exactly,
                # tests/devices/test_cues.py), or nothing on a failed tick
                cues = () if out.result is None else out.result.output.cues
                for device in devices:
                    device.submit(cues)
            t_end = (out.tick + 1) / tick_hz
            for device in devices:
                device.run_until(t_end)
            if out.state is not None:
                self.last_state = out.state.view
                self._emit(out.state)

    def advance_s(self, seconds: float) -> None:
        self.advance(max(1, round(seconds * self.tick_hz)))

    # -- plumbing ------------------------------------------------------------------------------
    def _send(self, record: Record) -> bool:
        """A record for the loop, applied between ticks as the loop process applies its mailbox."""
        self.core.apply(record, self.core.sim.data.tick * TICK_NS)
        records, self.core.outbox = self.core.outbox, []
        self._emit_all(records)
        return True

    def _emit_all(self, records) -> None:
        for record in records:
            self._emit(record)

    def _emit(self, record: Record) -> None:
        if type(record) is ScenarioAnnounce:
            self.control.announced(record.info)
        for listener in self.listeners:
            listener(record)

    def _settle_devices(self, timeout_s: float = 1.0) -> None:
        """Let every device finish its handshake before the study starts (as a rig at start-up)."""
        for _ in range(round(timeout_s * self.tick_hz)):
            if all(d.status == "connected" for d in self.devices.values()):
                return
            self.advance()
        raise RuntimeError(f"devices did not connect: {({n: d.status for n, d in self.devices.items()})}")
