"""The scenario registry: an explicit, frozen mapping from versioned ids to factories.

No registration by import side effect (Gymnasium's caveat): the table below is the whole list.
A bare name ("contact-angle") resolves to its newest version; an unknown name gets a
"did you mean" error.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from types import MappingProxyType
from typing import Callable

from server.core.scenario import ParamError, Scenario, check_params
from scenarios.contact_angle import ContactAngle
from scenarios.free import FreeExploration
from scenarios.friction_temperature import FrictionTemperature
from scenarios.hot_wire import HotWire
from scenarios.peg_in_hole import PegInHole
from scenarios.pick_place import PickPlace
from scenarios.positioning import Positioning
from scenarios.shape import ShapeScenario
from scenarios.stiffness import StiffnessScenario
from scenarios.stimulus import Stimulus
from scenarios.texture import TextureScenario


DEFAULT_SCENARIO = "contact-angle"  # what the server runs when it is told nothing (serve, LoopConfig, a virtual hub)


@dataclass(frozen=True)
class ScenarioSpec:
    id: str
    title: str
    factory: Callable[..., Scenario]


SCENARIOS = MappingProxyType({cls.id: ScenarioSpec(cls.id, cls.title, cls) for cls in (
    ContactAngle, TextureScenario, StiffnessScenario, ShapeScenario, FrictionTemperature, Positioning, PegInHole,
    HotWire, PickPlace, FreeExploration, Stimulus,
)})


class UnknownScenario(KeyError):
    def __str__(self) -> str:
        return self.args[0]


def resolve(name: str) -> ScenarioSpec:
    if name in SCENARIOS:
        return SCENARIOS[name]
    versions = sorted((sid for sid in SCENARIOS if sid.rsplit("-v", 1)[0] == name),
                      key=lambda sid: int(sid.rsplit("-v", 1)[1]))
    if versions:
        return SCENARIOS[versions[-1]]
    names = list(SCENARIOS) + sorted({sid.rsplit("-v", 1)[0] for sid in SCENARIOS})
    close = difflib.get_close_matches(name, names, n=3)
    hint = f"; did you mean {', '.join(close)}?" if close else ""
    raise UnknownScenario(f"unknown scenario {name!r}{hint} (known: {', '.join(SCENARIOS)})")


def check_scenario_params(spec: ScenarioSpec, params: dict) -> dict:
    """The parameters checked against the scenario's PARAMS, defaults filled in (ParamError)."""
    return check_params(spec.factory.PARAMS, params, spec.id)


def create(name: str, **params) -> Scenario:
    """A scenario with its parameters checked against its PARAMS (ParamError names the problem)."""
    spec = resolve(name)
    checked = check_scenario_params(spec, params)
    try:
        return spec.factory(**checked)
    except ValueError as exc:  # a combination the single-parameter checks cannot see (e.g. a bad skin path)
        raise ParamError(f"{spec.id}: {exc}") from None
