"""stimulus-v1: 1–4 timed intervals of one cue, for psychophysics (docs/scenarios.md "Stimulus").

A task fixes the cue and its fields (PARAMS); each trial says which field the procedure's level
drives and the level of every interval (TRIAL_PARAMS). From the first tick after `set_trial`,
interval k is on from `lead_ms + Σ_{j<k} (len_j + isi_ms)` for `len_k` ms, where `len` is
`duration_ms`, or the interval's level when the driven field is `duration_ms`. An interval whose
level is None is blank: marked (HUD, values, events) but with no cue. A Vibration or PulseTrain
in an interval carries `duration_ms = len_k`, so a device with its own clock (an audio tactor)
plays exactly that long; the others follow the ticks, on which the cue is emitted for `len_k` ms.

The scenario never ends a trial itself (no `finished` output): the participant's answer does.
Interval on and off are recorded as events at the ticks they happen. The requirement on the
devices follows the cue (`requires_for`): a tilt needs a device that shows macro-roughness, a
vibration any device.
"""

from __future__ import annotations

from typing import Any, Mapping

from server.core.cues import PulseTrain, Stiffness, Temperature, Texture, Tilt, Vibration, tilt_direction
from server.core.haptics.primitives import Plane, Pose
from server.core.scenario import (Param, ParamError, Pending, ScenarioOutput, TickContext, Trial, check_params)
from server.core.scene import Camera, Material, Scene, SceneObject

ID = "stimulus-v1"
MAX_INTERVALS = 4
CUE_CLASSES = {"vibration": Vibration, "pulse_train": PulseTrain, "texture": Texture, "tilt": Tilt,
               "stiffness": Stiffness, "temperature": Temperature}
# the tactile dimension (devices/capability.py) a device must show for each cue; none for a vibration
CUE_REQUIRES = {"vibration": (), "pulse_train": (), "texture": ("fine_roughness",), "tilt": ("macro_roughness",),
                "stiffness": ("stiffness",), "temperature": ("temperature",)}
MIN_DURATION_MS = 1.0  # one tick: an interval shorter than that would never be on
MAX_MS = Vibration.RANGES["duration_ms"][1]
CONTACT_ANGLE_RANGE = (-90.0, 90.0)  # the contact-angle task's range (scenarios/contact_angle.py)


def _cue_param(cls, name: str, doc: str, unit: str = "") -> Param:
    """An optional cue field, its range the cue class's RANGES; None: the cue's own default."""
    low, high = cls.RANGES[name]
    return Param(name, "number", doc, None, low, high, unit=unit, optional=True)


# The fields a level may drive: which cues have it, its range, its unit.
DRIVEN: dict[str, tuple[tuple[str, ...], tuple[float, float], str]] = {
    "intensity_pct": (("vibration", "pulse_train", "texture"), Vibration.RANGES["intensity_pct"], "%"),
    "carrier_hz": (("vibration", "pulse_train"), Vibration.RANGES["carrier_hz"], "Hz"),
    "duration_ms": (tuple(CUE_CLASSES), (MIN_DURATION_MS, MAX_MS), "ms"),
    "direction_deg": (("tilt",), Tilt.RANGES["direction_deg"], "deg"),
    "contact_angle_deg": (("tilt",), CONTACT_ANGLE_RANGE, "deg"),
    "period_us": (("texture",), Texture.RANGES["period_us"], "µs"),
    "relative": (("stiffness",), Stiffness.RANGES["relative"], ""),
    "celsius": (("temperature",), Temperature.RANGES["celsius"], "°C"),
    "magnitude_pct": (("tilt",), Tilt.RANGES["magnitude_pct"], "%"),
}
LEVEL_LOW = min(r[0] for _, r, _ in DRIVEN.values())
LEVEL_HIGH = max(r[1] for _, r, _ in DRIVEN.values())

# Which PARAMS each cue takes (the others must be left out).
CUE_FIELDS = {
    "vibration": ("intensity_pct", "carrier_hz"),
    "pulse_train": ("t_on_ms", "t_off_ms", "intensity_pct", "carrier_hz"),
    "texture": ("period_us", "duty", "intensity_pct"),
    "tilt": ("direction_deg", "magnitude_pct"),
    "stiffness": ("relative",),
    "temperature": ("celsius",),
}
CUE_FIELDS_ALL = tuple(sorted({name for names in CUE_FIELDS.values() for name in names}))


class Interval:
    """One interval of a trial, planned: on from `on_ms` to `off_ms` after the trial's first tick."""
    __slots__ = ("number", "on_ms", "off_ms", "cues")

    def __init__(self, number: int, on_ms: float, off_ms: float, cues: tuple):
        self.number, self.on_ms, self.off_ms, self.cues = number, on_ms, off_ms, cues


def plan_intervals(params: Mapping[str, Any], trial: Mapping[str, Any]) -> tuple[Interval, ...]:
    """The intervals of a trial (C1 timing): checked PARAMS and TRIAL_PARAMS in, pure."""
    driven, n = trial["parameter"], trial["n_intervals"]
    fields = {name: params[name] for name in CUE_FIELDS[params["cue"]] if params[name] is not None}
    cls = CUE_CLASSES[params["cue"]]
    out, start = [], params["lead_ms"]
    for k in range(1, n + 1):
        level = trial[f"level_{k}"]
        length = level if driven == "duration_ms" and level is not None else params["duration_ms"]
        cues: tuple = ()
        if level is not None:
            cue_fields = dict(fields)
            if driven == "contact_angle_deg":  # shown as the contact-angle task shows it: a tilt toward −angle
                cue_fields["direction_deg"] = tilt_direction(-level)
            elif driven != "duration_ms":
                cue_fields[driven] = level
            if cls in (Vibration, PulseTrain):
                cue_fields["duration_ms"] = length
            cues = (cls(**cue_fields),)
        out.append(Interval(k, start, start + length, cues))
        start += length + params["isi_ms"]
    return tuple(out)


class Stimulus:
    id = ID
    title = "Stimulus intervals (psychophysics: 1–4 timed intervals of one cue)"
    PARAMS = (
        Param("cue", "choice", "the cue every interval presents", "vibration", choices=tuple(CUE_CLASSES)),
        _cue_param(Vibration, "intensity_pct", "vibration, pulse train, texture: intensity (None: 100)", "%"),
        _cue_param(Vibration, "carrier_hz", "vibration, pulse train: carrier (None: the device's own)", "Hz"),
        _cue_param(PulseTrain, "t_on_ms", "pulse train: burst length (None: 50)", "ms"),
        _cue_param(PulseTrain, "t_off_ms", "pulse train: pause between bursts (None: 200)", "ms"),
        _cue_param(Texture, "period_us", "texture: period (None: 4000)", "µs"),
        _cue_param(Texture, "duty", "texture: duty cycle (None: 0.5)"),
        _cue_param(Tilt, "direction_deg", "tilt: direction, 0 front, 90 right (None: 0)", "deg"),
        _cue_param(Tilt, "magnitude_pct", "tilt: magnitude (None: 100)", "%"),
        _cue_param(Stiffness, "relative", "stiffness: between the softest (0) and stiffest (1) (None: 1)"),
        _cue_param(Temperature, "celsius", "temperature (None: 32)", "°C"),
        Param("duration_ms", "number", "each interval's length (unless the level drives it)", 500.0,
              MIN_DURATION_MS, MAX_MS, unit="ms"),
        Param("isi_ms", "number", "inter-stimulus interval: one interval's end to the next one's start", 500.0,
              0.0, MAX_MS, unit="ms"),
        Param("lead_ms", "number", "the trial's start to the first interval", 500.0, 0.0, MAX_MS, unit="ms"),
    )
    TRIAL_PARAMS = (
        Param("parameter", "choice", "the cue field the levels drive", "intensity_pct", choices=tuple(DRIVEN)),
        Param("n_intervals", "int", "how many intervals the trial presents", 1, 1, MAX_INTERVALS),
        *(Param(f"level_{k}", "number", f"the driven field's value in interval {k} (None: a blank interval, "
                "marked but with no cue); its range is the driven field's", None, LEVEL_LOW, LEVEL_HIGH,
                optional=True) for k in range(1, MAX_INTERVALS + 1)),
    )
    CONTROLS = ()
    SUBTASKS = ()
    REQUIRES = ()  # for the default cue (vibration); `requires_for` follows the `cue` PARAM

    @staticmethod
    def requires_for(params: Mapping[str, Any]) -> tuple[str, ...]:
        """The tactile dimensions a device must show for the chosen cue (server/core/scenario.py
        `required_dimensions`)."""
        return CUE_REQUIRES.get(params.get("cue", "vibration"), ())

    @classmethod
    def check_trial(cls, params: Mapping[str, Any], trial: Mapping[str, Any], where: str = "trial") -> None:
        """ParamError naming the field when a trial's settings do not fit the task's cue: the
        driven field must be one the cue has, each level within that field's range, and no level
        beyond `n_intervals`. `params`: the scenario's PARAMS; `trial`: checked TRIAL_PARAMS."""
        params = check_params(cls.PARAMS, params, ID)
        driven, cue = trial["parameter"], params["cue"]
        cues, (low, high), unit = DRIVEN[driven]
        if cue not in cues:
            raise ParamError(f"{where}.parameter {driven!r} is not a field of a {cue} cue; it drives one of: "
                             f"{', '.join(p for p, (c, _, _) in DRIVEN.items() if cue in c)}")
        for k in range(1, MAX_INTERVALS + 1):
            level = trial.get(f"level_{k}")
            if level is None:
                continue
            if k > trial["n_intervals"]:
                raise ParamError(f"{where}.level_{k} is set but the trial has {trial['n_intervals']} interval(s)")
            if not low <= level <= high:
                raise ParamError(f"{where}.level_{k} must be in [{low}, {high}]{' ' + unit if unit else ''} "
                                 f"for {driven}, got {level!r}")

    def __init__(self, cue: str = "vibration", intensity_pct: float | None = None, carrier_hz: float | None = None,
                 t_on_ms: float | None = None, t_off_ms: float | None = None, period_us: float | None = None,
                 duty: float | None = None, direction_deg: float | None = None, magnitude_pct: float | None = None,
                 relative: float | None = None, celsius: float | None = None, duration_ms: float = 500.0,
                 isi_ms: float = 500.0, lead_ms: float = 500.0):
        params = dict(locals())
        del params["self"]
        unused = [name for name in CUE_FIELDS_ALL if params[name] is not None and name not in CUE_FIELDS[cue]]
        if unused:  # a field the cue does not have would silently do nothing
            raise ValueError(f"{', '.join(unused)}: not a field of a {cue} cue (it takes "
                             f"{', '.join(CUE_FIELDS[cue])})")
        self.params = params
        self.reset(0)

    def build_scene(self) -> Scene:
        ground = SceneObject("ground", Plane((2.0, 2.0)), Pose(), Material("#6f7378"))
        camera = Camera("perspective", position=(3.0, 0.0, 1.5), target=(0.0, 0.0, 0.0), up=(0.0, 0.0, 1.0),
                        fov_deg=45.0)
        return Scene("stimulus", (ground,), camera, hud_text="")

    def reset(self, seed: int) -> None:
        """No random choices: a trial's intervals follow from its settings alone."""
        self.trial: Trial | None = None
        self.intervals: tuple[Interval, ...] = ()
        self.start_s: float | None = None  # the trial's first tick, stamped by the next step
        self.boundary = 0  # how many on/off boundaries (2 per interval) have passed
        self.refused = ""  # why the running trial presents nothing (settings that do not fit the cue)
        self.pending = Pending()

    def set_trial(self, trial: Trial | None) -> None:
        if self.boundary % 2 == 1:  # ended in the middle of an interval: its end is recorded, cut short
            self.pending.emit("interval_off", interval=self.intervals[self.boundary // 2].number, cut=True)
        self.trial, self.start_s, self.boundary, self.refused, self.intervals = trial, None, 0, "", ()
        if trial is None:
            return
        try:  # the hub checked it (ScenarioControl.set_trial); a trial that still does not fit shows why
            self.check_trial(self.params, trial.params)
        except ParamError as exc:
            self.refused = str(exc)
            self.pending.emit("trial_refused", reason=self.refused)
            return
        self.intervals = plan_intervals(self.params, trial.params)

    def on_input(self, key: str, action: str, value: Any = None) -> None:
        """No keys: the answer is a question of the study (the participant's page)."""

    def step(self, ctx: TickContext) -> ScenarioOutput:
        if self.trial is None or self.refused:
            return self.pending.flush(hud=self.refused)
        if self.start_s is None:
            self.start_s = ctx.t_s
        # rounded to 1 ns: tick / tick_hz differences are not exact in binary (0.5 s must read 500 ms)
        elapsed_ms = round((ctx.t_s - self.start_s) * 1000.0, 6)
        intervals = self.intervals
        while self.boundary < 2 * len(intervals):
            interval = intervals[self.boundary // 2]
            on = self.boundary % 2 == 0
            if elapsed_ms < (interval.on_ms if on else interval.off_ms):
                break
            self.pending.emit("interval_on" if on else "interval_off", interval=interval.number)
            self.boundary += 1
        b, n = self.boundary, len(intervals)
        cues: tuple = ()
        if b == 2 * n:
            stage, number, hud = "respond", 0, "Answer now"
        elif b % 2 == 1:
            interval = intervals[b // 2]
            stage, number, hud, cues = "interval", interval.number, f"Interval {interval.number}", interval.cues
        else:
            stage, number, hud = ("lead", 0, "Get ready") if b == 0 else ("isi", 0, "")
        if ctx.refusals:  # a device that cannot show the cue says so; the participant must not just feel nothing
            hud = "; ".join(ctx.refusals)
        return self.pending.flush(cues=cues, hud=hud, values={"interval": number, "n_intervals": n, "stage": stage})

