"""A stand-in for the stimulus scenario of Contract C1 (scenarios/stimulus.py, the stimulus
part's), for this branch's tests only: the same ID, PARAMS and TRIAL_PARAMS names, intervals on
the tick clock. `install()` registers it only while the registry has no "stimulus" of its own,
so once the real scenario is on main this module does nothing and the tests run against it.
Tests use the `stimulus` fixture (tests/experiment/conftest.py), which undoes the registration."""

from __future__ import annotations

from types import MappingProxyType

from scenarios import registry
from server.core.cues import Temperature, Tilt, Vibration
from server.core.scenario import Param, ScenarioOutput, TickContext, Trial
from server.core.scene import Scene
from scenarios.free import sandbox

ID = "stimulus-v1"
_PARAMETERS = ("intensity_pct", "carrier_hz", "duration_ms", "direction_deg", "contact_angle_deg", "period_us",
               "relative", "celsius", "magnitude_pct")


class StimulusStandIn:
    id = ID
    title = "Psychophysics stimulus (test stand-in for Contract C1)"
    PARAMS = (
        Param("cue", "choice", "cue kind", "vibration",
              choices=("vibration", "pulse_train", "texture", "tilt", "stiffness", "temperature")),
        Param("intensity_pct", "number", "intensity", 100.0, 0.0, 100.0),
        Param("carrier_hz", "number", "carrier", None, 1.0, 2000.0, optional=True),
        Param("t_on_ms", "number", "pulse on", 50.0, 0.0, 60000.0),
        Param("t_off_ms", "number", "pulse off", 50.0, 0.0, 60000.0),
        Param("period_us", "number", "texture period", 4000.0, 100.0, 1e6),
        Param("duty", "number", "texture duty", 0.5, 0.0, 1.0),
        Param("direction_deg", "number", "tilt direction", 0.0, 0.0, 360.0),
        Param("magnitude_pct", "number", "tilt magnitude", 100.0, 0.0, 100.0),
        Param("relative", "number", "stiffness", 1.0, 0.0, 1.0),
        Param("celsius", "number", "temperature", 32.0, 0.0, 50.0),
        Param("duration_ms", "number", "interval length", 500.0, 1.0, 60000.0),
        Param("isi_ms", "number", "between intervals", 500.0, 0.0, 60000.0),
        Param("lead_ms", "number", "before the first interval", 500.0, 0.0, 60000.0),
    )
    TRIAL_PARAMS = (
        Param("parameter", "choice", "the driven field", "intensity_pct", choices=_PARAMETERS),
        Param("n_intervals", "int", "intervals", 1, 1, 4),
        *(Param(f"level_{k}", "number", f"interval {k}", None, -1e9, 1e9, optional=True) for k in range(1, 5)),
    )
    CONTROLS = ()
    SUBTASKS = ()
    REQUIRES = ()

    def __init__(self, **params):
        self.params = params
        self.trial: Trial | None = None
        self.first_tick: float | None = None

    def build_scene(self) -> Scene:
        return sandbox()

    def reset(self, seed: int) -> None:
        self.first_tick = None

    def set_trial(self, trial: Trial | None) -> None:
        self.trial, self.first_tick = trial, None

    def on_input(self, key: str, action: str, value=None) -> None:
        """No keys."""

    def _lengths(self) -> list[float]:
        t = self.trial.params
        return [float(t[f"level_{k}"] or 0.0) if t["parameter"] == "duration_ms" else self.params["duration_ms"]
                for k in range(1, t["n_intervals"] + 1)]

    def step(self, ctx: TickContext) -> ScenarioOutput:
        if self.trial is None:
            return ScenarioOutput()
        if self.first_tick is None:
            self.first_tick = ctx.t_s
        ms = (ctx.t_s - self.first_tick) * 1000.0
        t, on = self.params["lead_ms"], None
        n = self.trial.params["n_intervals"]
        for k, length in enumerate(self._lengths(), 1):
            if t <= ms < t + length:
                on = k
                break
            t += length + self.params["isi_ms"]
        values = {"interval": on or 0, "n_intervals": n,
                  "stage": "interval" if on else ("lead" if ms < self.params["lead_ms"] else "respond")}
        cues = ()
        level = self.trial.params.get(f"level_{on}") if on else None
        if level is not None:
            cues = (self._cue(self.trial.params["parameter"], level),)
        return ScenarioOutput(cues=cues, values=values, hud=f"Interval {on}" if on else "Answer now")

    def _cue(self, parameter: str, level: float):
        p = {**self.params, parameter: level}
        if p["cue"] == "tilt":
            direction = (-level) % 360 if parameter == "contact_angle_deg" else p["direction_deg"]
            return Tilt(direction, p["magnitude_pct"])
        if p["cue"] == "temperature":
            return Temperature(p["celsius"])
        return Vibration(p["intensity_pct"], p["carrier_hz"])


def registered() -> MappingProxyType:
    """The registry's scenarios with the stand-in, unless it already has a stimulus scenario."""
    if any(sid.startswith("stimulus-v") for sid in registry.SCENARIOS):
        return registry.SCENARIOS
    return MappingProxyType({**registry.SCENARIOS, ID: registry.ScenarioSpec(ID, StimulusStandIn.title,
                                                                             StimulusStandIn)})


def install() -> None:
    """Register the stand-in for this process (a server a live test starts: its sitecustomize calls this)."""
    registry.SCENARIOS = registered()
