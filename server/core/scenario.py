"""The scenario interface: one small contract for every virtual task (Gymnasium-like).

A scenario builds its static Scene once, then is stepped by the loop every tick with a read-only
TickContext (what the haptic renderer found) and answers with device-independent cues, HUD text,
values worth showing or recording, and changes to its objects. It does no I/O and reads no
clock: time comes in the context, so a study replays identically on the virtual clock.

Besides the per-tick contract, a scenario declares as class data what the experiment engine,
the console and the hub need without running it:
- PARAMS: constructor parameters (a study condition's scenario settings);
- TRIAL_PARAMS: what one trial sets (`set_trial`), e.g. the angle to present;
- CONTROLS: the keys and experimenter commands it reacts to, who may send them, and the value a
  command carries (the hub checks role and value before anything reaches the loop);
- SUBTASKS: the thesis's study parts with their conditions and answer scales (docs/reference.md
  "Study");
- REQUIRES: the tactile dimensions (thesis Table 2.2) of which a device must show at least one
  (a scenario whose requirement follows one of its PARAMS adds `requires_for(params)`,
  `required_dimensions` below).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, ClassVar, Mapping, NamedTuple, Protocol

from server.core.cues import Cue
from server.core.frozen import quick_init
from server.core.haptics.primitives import Pose
from server.core.haptics.vec import Vec3
from server.core.numbers import is_finite_number
from server.core.scene import Scene

PHASES = ("training", "trial", "main")  # the thesis's study design (docs/reference.md "Study")
PARAM_KINDS = ("number", "int", "choice", "bool", "text")
ROLES_FOR_CONTROLS = ("participant", "operator")


class ParamError(ValueError):
    """A parameter, trial setting or command value that cannot be used; the message names it."""


@dataclass(frozen=True)
class Param:
    name: str
    kind: str               # one of PARAM_KINDS
    doc: str
    default: Any = None     # None: required, unless optional
    low: float | None = None
    high: float | None = None
    choices: tuple = ()
    unit: str = ""
    labels: Mapping[int, str] = field(default_factory=dict)  # anchor labels of a rating scale
    optional: bool = False  # may be left out (then None)

    def __post_init__(self) -> None:
        if self.kind not in PARAM_KINDS:
            raise ValueError(f"parameter {self.name}: kind must be one of {', '.join(PARAM_KINDS)}")

    def check(self, value: Any, where: str = "") -> Any:
        """The value converted to its kind, or ParamError naming the parameter and the rule."""
        name = f"{where}.{self.name}" if where else self.name
        if value is None and self.optional:
            return None
        if self.kind == "bool":
            if not isinstance(value, bool):
                raise ParamError(f"{name} must be true or false, got {value!r}")
            return value
        if self.kind == "text":
            if not isinstance(value, str) or len(value) > 200:
                raise ParamError(f"{name} must be a string of at most 200 characters")
            return value
        if self.kind == "choice":
            if value not in self.choices or isinstance(value, bool):
                raise ParamError(f"{name} must be one of {', '.join(map(str, self.choices))}, got {value!r}")
            return self.choices[self.choices.index(value)]  # 3000 → 3000.0: the declared form
        if not is_finite_number(value):
            raise ParamError(f"{name} must be a finite number, got {value!r}")
        if self.kind == "int":
            if value != int(value):
                raise ParamError(f"{name} must be a whole number, got {value!r}")
            value = int(value)
        else:
            value = float(value)
        if (self.low is not None and value < self.low) or (self.high is not None and value > self.high):
            raise ParamError(f"{name} must be in [{self.low}, {self.high}]{' ' + self.unit if self.unit else ''}, "
                             f"got {value!r}")
        return value

    def to_dict(self) -> dict:
        d: dict[str, Any] = {"name": self.name, "kind": self.kind, "doc": self.doc, "default": self.default,
                             "optional": self.optional}
        if self.low is not None or self.high is not None:
            d["low"], d["high"] = self.low, self.high
        if self.choices:
            d["choices"] = list(self.choices)
        if self.unit:
            d["unit"] = self.unit
        if self.labels:
            d["labels"] = {str(k): v for k, v in self.labels.items()}
        return d


def check_params(specs: tuple[Param, ...], given: Mapping[str, Any] | None, where: str) -> dict[str, Any]:
    """Validate `given` against `specs` and fill in defaults; unknown or missing names are errors."""
    given = dict(given or {})
    known = {p.name: p for p in specs}
    unknown = sorted(set(given) - set(known))
    if unknown:
        allowed = ", ".join(known) or "none"
        raise ParamError(f"{where}: unknown parameter(s) {', '.join(unknown)}; allowed: {allowed}")
    out = {}
    for p in specs:
        if p.name in given:
            out[p.name] = p.check(given[p.name], where)
        elif p.default is None and not p.optional:
            raise ParamError(f"{where}: parameter {p.name} is required ({p.doc})")
        else:
            out[p.name] = p.default
    return out


@dataclass(frozen=True)
class Control:
    key: str                # a DOM KeyboardEvent.key ("ArrowUp", "r") or a command name ("tap_angle")
    doc: str
    who: str = "participant"  # "participant": any client that may send input; "operator": operators only
    value: Param | None = None  # the value a command carries (None: no value)

    def to_dict(self) -> dict:
        return {"key": self.key, "doc": self.doc, "who": self.who,
                "value": self.value.to_dict() if self.value else None}


def find_control(controls: tuple[Control, ...], key: str) -> Control | None:
    return next((c for c in controls if c.key == key), None)


@dataclass(frozen=True)
class SubTask:
    """One part of a scenario's study (docs/reference.md "Study"): main-trial conditions and the
    answer scale. The experiment engine orders the conditions; this is the design, not the order."""
    name: str
    title: str
    conditions: tuple[Mapping[str, Any], ...]  # TRIAL_PARAMS of each main trial
    answer: Param | None                       # None: the scenario records the result itself
    practice_trials: int = 0                   # trial-phase trials before the main ones
    training_s: float = 0.0                    # suggested training time
    time_limit_s: float | None = None          # per main trial
    question: str = ""

    def to_dict(self) -> dict:
        return {"name": self.name, "title": self.title, "conditions": [dict(c) for c in self.conditions],
                "answer": self.answer.to_dict() if self.answer else None, "practice_trials": self.practice_trials,
                "training_s": self.training_s, "time_limit_s": self.time_limit_s, "question": self.question}


@dataclass(frozen=True)
class Trial:
    phase: str                      # one of PHASES
    params: Mapping[str, Any]       # validated TRIAL_PARAMS
    index: int = 0                  # trial number within its phase, for the HUD

    @classmethod
    def parse(cls, specs: tuple[Param, ...], phase: Any, params: Mapping[str, Any] | None, index: Any = 0,
              where: str = "trial") -> Trial:
        if phase not in PHASES:
            raise ParamError(f"{where}.phase must be one of {', '.join(PHASES)}, got {phase!r}")
        if isinstance(index, bool) or not isinstance(index, int) or index < 0:
            raise ParamError(f"{where}.index must be an integer >= 0")
        return cls(phase, MappingProxyType(check_params(specs, params, where)), index)

    def to_dict(self) -> dict:
        return {"phase": self.phase, "params": dict(self.params), "index": self.index}

    def __deepcopy__(self, memo: dict) -> Trial:
        return self  # immutable (frozen, read-only params): a copy of a simulation shares it (Simulation.snapshot)

    @property
    def title(self) -> str:
        """What the participant's HUD calls this trial: "Practice 2" (trial phase), "Trial 3"."""
        return f"{'Practice' if self.phase == 'trial' else 'Trial'} {self.index + 1}"


class ToolView(NamedTuple):
    """One tool (a tracked point and its god-object) as the scenario sees it in a tick. Tools are
    named by the point that drives them (server/core/points.py), e.g. "right.thumb.tip"."""
    name: str
    hip: Vec3              # tracked (or held) position
    proxy: Vec3            # god-object proxy
    contact: bool          # debounced contact (this tool's own gate)
    touching: frozenset[str]  # bodies its proxy touches this tick (raw)
    force: Vec3            # k·(proxy − hip), newtons
    lost: bool             # its tracker source stopped (ttl passed): the tool is home, out of contact
    driven: bool = True    # a tracker source drives it now (False: it rests at home; a mouse drives one point)


class _NoToolCues(Mapping):
    """The empty, immutable (so shareable) default of ScenarioOutput.tool_cues."""
    __slots__ = ()

    def __getitem__(self, key: str) -> tuple[Cue, ...]:
        raise KeyError(key)

    def __iter__(self):
        return iter(())

    def __len__(self) -> int:
        return 0

    def __hash__(self) -> int:
        return 0

    def __reduce__(self) -> str:
        return "NO_TOOL_CUES"  # copied or pickled, the one shared instance (compared by identity)


NO_TOOL_CUES: Mapping[str, tuple[Cue, ...]] = _NoToolCues()
_NOTHING: Mapping = MappingProxyType({})  # an output's change buffer with nothing in it (Pending.flush)


@quick_init  # built every tick (server/core/frozen.py)
@dataclass(frozen=True)
class TickContext:
    tick: int              # loop tick counter
    t_s: float             # simulation time = tick / tick_hz, seconds
    hip: Vec3              # tracked HIP (or the held HIP, see ScenarioOutput.hold_hip), scene frame
    proxy: Vec3            # god-object proxy
    contact: bool          # debounced contact (hysteresis gate)
    touching: frozenset[str]  # bodies the proxy touches this tick (raw)
    nearest: str | None    # haptic body nearest to the HIP
    refusals: tuple[str, ...] = ()  # cues a connected device refused, with reasons (devices.encoder)
    sticking: bool = False  # the proxy is held by static friction (god-object friction cone)
    # Every tool, primary first (tools[0] is hip/proxy/contact/touching above); one per rig point.
    tools: tuple[ToolView, ...] = ()
    # False when no client draws this run (a simulated study): what only a viewer shows, the
    # output's `values`, may be left empty. The HUD is still read (a synthetic participant reads it).
    drawn: bool = True


@quick_init  # built every tick
@dataclass(frozen=True)
class ScenarioOutput:
    cues: tuple[Cue, ...] = ()   # the primary tool's devices' cues
    hud: str = ""
    values: dict = field(default_factory=dict)
    poses: dict[str, Pose] = field(default_factory=dict)        # objects moved this tick
    visible: dict[str, bool] = field(default_factory=dict)      # objects/overlays shown or hidden this tick
    touchable: dict[str, bool] = field(default_factory=dict)    # bodies made touchable or not this tick
    stiffness: dict[str, float] = field(default_factory=dict)   # bodies whose spring k changed this tick
    scales: dict[str, tuple[float, float, float]] = field(default_factory=dict)  # drawn size factors (scene axes)
    hold_hip: Vec3 | None = None  # hold the HIP here from the next tick on (experimenter's tap); None: tracker
    events: tuple[dict, ...] = ()  # things worth recording with their tick (key presses, taps)
    held: str | None = None  # the object the participant carries (recorded with the trajectory)
    finished: Mapping[str, Any] | None = None  # the running trial ended this tick: its metrics (recorded)
    # Cues for the devices of other tools, by tool name (a rig file's `finger`); a tool not named
    # here gets none. The primary tool's cues are `cues` (a key naming it here is ignored).
    tool_cues: Mapping[str, tuple[Cue, ...]] = NO_TOOL_CUES


class Pending:
    """What a scenario has to report in its next output, collected between two steps (inputs, trial
    changes and the step itself add to it): events, a trial's end, and changes to its objects.

    The one owner of these buffers: `flush` builds the step's ScenarioOutput with all of them and
    starts over empty, so every change goes out exactly once and none is forgotten."""

    def __init__(self) -> None:
        self._clear()

    def _clear(self) -> None:
        self.events: list[dict] = []
        self.finished: dict[str, Any] | None = None
        self.poses: dict[str, Pose] = {}
        self.visible: dict[str, bool] = {}
        self.touchable: dict[str, bool] = {}
        self.stiffness: dict[str, float] = {}
        self.scales: dict[str, tuple[float, float, float]] = {}

    def emit(self, name: str, **fields: Any) -> None:
        """An event worth recording (the loop stamps it with its tick)."""
        self.events.append({"name": name, **fields})

    def finish(self, metrics: Mapping[str, Any]) -> None:
        """The running trial ended: its metrics become `ScenarioOutput.finished` and, for clients and
        exports that show events, a `trial_done` event with the same fields."""
        self.finished = dict(metrics)
        self.emit("trial_done", **metrics)

    def flush(self, cues: tuple = (), hud: str = "", values: dict | None = None, hold_hip: Vec3 | None = None,
              held: str | None = None, tool_cues: Mapping[str, tuple[Cue, ...]] = NO_TOOL_CUES) -> ScenarioOutput:
        """This step's output: the step's cues, hud, values, hold_hip, held and tool_cues, and
        everything pending. A buffer with nothing in it is handed on as the shared empty mapping and
        kept (most ticks change nothing but a pose): only a filled one is replaced."""
        events, finished = self.events, self.finished
        poses, visible, touchable, stiffness, scales = self.poses, self.visible, self.touchable, self.stiffness, self.scales
        out = ScenarioOutput(cues, hud, {} if values is None else values,
                             poses or _NOTHING, visible or _NOTHING, touchable or _NOTHING, stiffness or _NOTHING,
                             scales or _NOTHING, hold_hip, tuple(events) if events else (), held, finished,
                             tool_cues)
        if events:
            self.events = []
        self.finished = None
        if poses:
            self.poses = {}
        if visible:
            self.visible = {}
        if touchable:
            self.touchable = {}
        if stiffness:
            self.stiffness = {}
        if scales:
            self.scales = {}
        return out


class Scenario(Protocol):
    id: str      # versioned id, e.g. "contact-angle-v1"
    title: str
    # The tools (point names, server/core/points.py) the scenario needs besides what the rig has,
    # e.g. ("right.index.tip", "right.thumb.tip") for a grasp; empty: whatever the rig has.
    fingers: ClassVar[tuple[str, ...]]
    PARAMS: ClassVar[tuple[Param, ...]]
    TRIAL_PARAMS: ClassVar[tuple[Param, ...]]
    CONTROLS: ClassVar[tuple[Control, ...]]
    SUBTASKS: ClassVar[tuple[SubTask, ...]]
    REQUIRES: ClassVar[tuple[str, ...]]

    def build_scene(self) -> Scene: ...

    def reset(self, seed: int) -> None: ...

    def set_trial(self, trial: Trial | None) -> None: ...

    def step(self, ctx: TickContext) -> ScenarioOutput: ...

    def on_input(self, key: str, action: str, value: Any = None) -> None: ...


def describe(cls) -> dict:
    """What a scenario class declares, as plain data (REST, console, docs)."""
    return {"id": cls.id, "title": cls.title, "params": [p.to_dict() for p in cls.PARAMS],
            "trial_params": [p.to_dict() for p in cls.TRIAL_PARAMS],
            "controls": [c.to_dict() for c in cls.CONTROLS], "subtasks": [s.to_dict() for s in cls.SUBTASKS],
            "requires": list(cls.REQUIRES)}


def required_dimensions(cls, params: Mapping[str, Any] | None = None) -> tuple[str, ...]:
    """The tactile dimensions `cls` requires when built with `params`: its REQUIRES, or what its
    `requires_for(params)` says when the requirement follows a parameter (stimulus-v1's `cue`,
    which a class-level tuple cannot express). `params` None: the class's REQUIRES."""
    by_params = getattr(cls, "requires_for", None)
    return tuple(cls.REQUIRES) if by_params is None or params is None else tuple(by_params(params))


def in_contact_with(ctx: TickContext, body_ids) -> str | None:
    """The body of `body_ids` the HIP is in (debounced) contact with, or None.

    Touched bodies come first; at a crease (sphere on the ground) the proxy may touch both, and
    after the raw contact drops inside the hysteresis dwell only `nearest` still names one."""
    if not ctx.contact:
        return None
    for body in body_ids:
        if body in ctx.touching:
            return body
    return ctx.nearest if ctx.nearest in body_ids else None
