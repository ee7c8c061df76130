"""Scenario control: the checks and records of every request that changes what the loop runs.

Keys and experimenter commands (role and value against the scenario's CONTROLS), scenario
switches (parameters, construction, the capability check) and trials (TRIAL_PARAMS) are checked
here before anything reaches the loop; what passes becomes one record for the loop, handed to the
injected `send(record) -> bool`. The hub (WebSocket input and REST) and the simulated study's
virtual hub both delegate to this one class, so a simulated study obeys the same rules as a live
one. Sans-I/O: no web framework, no socket; `send` returning False (the loop's mailbox is full)
raises BusyError and nothing changes here.

Errors (REST and the hub map them to HTTP codes and `error` messages): ParamError (a bad value),
PermissionError (a command the sender's role may not send), registry.UnknownScenario,
ScenarioRefused (no configured device shows the scenario), DeviceMissing (a trial needs a device
that is not connected), BusyError.
"""

from __future__ import annotations

from dataclasses import replace
from itertools import count
from typing import Any, Callable, Mapping

from devices.capability import CHECK_CABLE, CapabilityReport, check, device_advice, missing_device_text, showing
from scenarios import registry
from server.core.scenario import ParamError, Trial, describe, find_control, required_dimensions
from server.ipc import records


class ScenarioRefused(Exception):
    """A scenario switch that the capability check refuses (no device shows what it is about)."""

    def __init__(self, report: CapabilityReport):
        super().__init__(report.message)
        self.report = report


class DeviceMissing(ScenarioRefused):
    """A trial refused because a required dimension is shown only by devices that are not
    connected (report.missing names them); `force` starts it anyway."""

    def __init__(self, report: CapabilityReport, advice: Mapping[str, str] | None = None):
        advice = advice or {}
        text = "; ".join(missing_device_text(report.scenario, m.dimension, device, status,
                                             advice.get(device, CHECK_CABLE))
                         for m in report.missing for device, status in zip(m.devices, m.statuses))
        super().__init__(replace(report, message=text + ". The trial was not started (force: true starts it anyway)."))


class BusyError(RuntimeError):
    """The loop's mailbox is full; the request was dropped."""


class ScenarioControl:
    """The one owner of "which scenario runs": what was asked (the last switch sent), which
    switches are in flight (by number), and what the loop announced (`state`); every reader (the
    hub's health feed and REST, the engine through the hub, the loop supervisor when it restarts
    the loop, the virtual hub) reads it here.

    `send`: hands one record to the loop (False: dropped). `profiles`: the device profiles by
    name as they are now (for the capability check); `statuses`: each device's connection status
    as last reported (a device not in it counts as connected)."""

    def __init__(self, send: Callable[[records.Record], bool], profiles: Callable[[], Mapping[str, Any]],
                 statuses: Callable[[], Mapping[str, str]] = dict):
        self.send = send
        self.profiles = profiles
        self.statuses = statuses
        self.scenario_cls = None  # the scenario the loop runs (or was last told to run)
        self.state: dict | None = None  # what the loop last announced: id, params, seed, trial (tick, switch)
        self._numbers = count(1)  # switches are numbered: the loop echoes the number when it settles one
        self._in_flight: list[int] = []  # numbers of the switches sent that the loop has not settled yet
        self._settled = 0  # the highest switch number the loop announced
        self._asked: dict | None = None  # the last switch sent: {"id", "params", "seed"}

    def target(self) -> Mapping[str, Any] | None:
        """What the loop runs once the switches in flight land: the last switch sent, or what it
        announced when none is in flight (the engine decides from this whether a trial needs a
        switch; the loop builds a switch off the tick, so its announcement comes later)."""
        return self._asked if self._in_flight else self.state

    def announced(self, state: dict) -> None:
        """The loop announced what it runs (its `scenario` record). Its `switch` is the number of
        the last switch it settled: installed, or failed to build (then `failed` names it and the
        state is what goes on); a switch superseded before its build is settled with the later
        one. An announcement written before the loop read a switch (a trial's end) carries an
        older number, so it settles nothing sent after it, even a switch back to the same
        scenario with new parameters (A, B, A: matched by number, not by id), and it does not
        undo `scenario_cls`: a trial sent next is for the scenario asked for."""
        self.state = state
        settled = state.get("switch", 0)
        self._settled = max(self._settled, settled)
        self._in_flight = [n for n in self._in_flight if n > settled]
        if not self._in_flight:
            self.scenario_cls = registry.resolve(state["id"]).factory

    def loop_restarted(self) -> None:
        """A new loop process runs what it was started with: nothing it was asked is in flight."""
        self._in_flight.clear()

    def is_operator_command(self, key: str) -> bool:
        """`key` is one of the running scenario's experimenter-only commands (`who == "operator"`)."""
        control = find_control(self.scenario_cls.CONTROLS, key) if self.scenario_cls else None
        return control is not None and control.who == "operator"

    def command(self, key: str, action: str, value=None, *, role: str = "operator", client_id: int | str = 0) -> None:
        """A key or experimenter command for the running scenario, checked against its CONTROLS:
        operator-only commands from other roles are forbidden, a command's value must fit its
        spec. Keys the scenario does not declare pass through (keyboards send every key)."""
        control = find_control(self.scenario_cls.CONTROLS, key) if self.scenario_cls else None
        if control is None:
            if value is not None:
                raise ParamError(f"the running scenario has no command {key!r} that takes a value")
        else:
            if control.who == "operator" and role != "operator":
                raise PermissionError(f"{key!r} is an experimenter command; a {role} may not send it")
            if control.value is None and value is not None:
                raise ParamError(f"{key!r} takes no value")
            if control.value is not None and action != "up":
                if value is None:
                    raise ParamError(f"{key!r} needs a value: {control.value.doc}")
                value = control.value.check(value, key)
        record = records.Input(client_id, key, action, value)
        if not self.send(record):
            raise BusyError("the loop's input mailbox is full; input dropped")

    def requires(self, scenario_cls=None, params: Mapping[str, Any] | None = None) -> tuple[str, ...]:
        """The dimensions `scenario_cls` (default: the running one) requires with `params` (default:
        the parameters it runs or was last asked to run with, when it is that scenario)."""
        cls = scenario_cls or self.scenario_cls
        return required_dimensions(cls, self._params_of(cls) if params is None else params)

    def _params_of(self, cls) -> Mapping[str, Any] | None:
        """The parameters `cls` runs (or was last asked to run) with; None when it is not the target."""
        target = self.target() or {}
        return target.get("params") if target.get("id") == cls.id else None

    def capability(self, scenario_cls=None, params: Mapping[str, Any] | None = None) -> CapabilityReport:
        cls = scenario_cls or self.scenario_cls
        return check(cls.id, self.requires(cls, params), self.profiles(), self.statuses())

    def devices_needed(self, scenario: str | None = None) -> dict[str, tuple[str, ...]]:
        """Per tactile dimension `scenario` (default: the running one) requires, the configured
        devices that show it (devices/capability.py `showing`): the recorder flags a trial while
        none of a dimension's devices is connected."""
        cls = registry.resolve(scenario).factory if scenario else self.scenario_cls
        return {} if cls is None else showing(self.requires(cls), self.profiles())

    def require_devices(self, scenario: str | None = None, force: bool = False) -> None:
        """DeviceMissing unless every required dimension of `scenario` (default: the running one)
        that a configured device shows is shown by a connected one, or `force`."""
        cls = registry.resolve(scenario).factory if scenario else self.scenario_cls
        if cls is None or force:
            return
        report = self.capability(cls)
        if report.missing:
            raise DeviceMissing(report, {name: device_advice(p) for name, p in self.profiles().items()})

    def switch_scenario(self, name: str, params: dict | None = None, seed: int = 0, force: bool = False) -> dict:
        """Ask the loop to run another scenario (registry.UnknownScenario, ParamError,
        ScenarioRefused, BusyError on bad requests; nothing is sent then)."""
        spec = registry.resolve(name)
        checked = registry.check_scenario_params(spec, params or {})
        registry.create(spec.id, **checked)  # constructing is cheap and finds what per-parameter checks cannot
        report = self.capability(spec.factory, checked)
        if not report.ok and not force:
            raise ScenarioRefused(report)
        number = next(self._numbers)
        if not self.send(records.SwitchScenario(spec.id, checked, seed, number)):
            raise BusyError("the loop's input mailbox is full; try again")
        # the mailbox is ordered: a trial or command sent next is for the new scenario
        self.scenario_cls = spec.factory
        if number > self._settled:  # (a loop that builds at once, the virtual hub's, settled it already)
            self._in_flight.append(number)
        self._asked = {"id": spec.id, "params": checked, "seed": seed}
        return {"id": spec.id, "params": checked, "seed": seed, "capability": report.to_dict()}

    def set_trial(self, phase: str | None, params: dict | None = None, index: int = 0,
                  force: bool = False) -> dict | None:
        """Start a trial of the running scenario (phase None ends it); DeviceMissing when a
        device it needs is not connected, unless `force`."""
        trial = None
        if phase is not None:
            if self.scenario_cls is None:
                raise ParamError("no scenario is running yet")
            trial = Trial.parse(self.scenario_cls.TRIAL_PARAMS, phase, params, index).to_dict()
            check_trial = getattr(self.scenario_cls, "check_trial", None)  # settings that must fit the PARAMS
            if check_trial is not None:
                check_trial(self._params_of(self.scenario_cls) or {}, trial["params"])
            self.require_devices(force=force)
        if not self.send(records.Trial(trial)):
            raise BusyError("the loop's input mailbox is full; try again")
        return trial

    def info(self, scene_hash: str) -> dict:
        """The running scenario as REST shows it: what the loop announced (its switch number is
        the hub's business), the scene it announced with it, the declaration and the capability
        check."""
        state = self.state
        if self.scenario_cls is None or state is None:
            return {}
        return {**{k: v for k, v in state.items() if k != "switch"}, "scene": scene_hash, "info": describe(self.scenario_cls),
                "capability": self.capability().to_dict()}
