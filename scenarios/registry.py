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

from scenarios.base import Scenario
from scenarios.contact_angle import ContactAngle


@dataclass(frozen=True)
class ScenarioSpec:
    id: str
    title: str
    factory: Callable[..., Scenario]


SCENARIOS = MappingProxyType({spec.id: spec for spec in (
    ScenarioSpec(ContactAngle.id, ContactAngle.title, ContactAngle),
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


def create(name: str, **params) -> Scenario:
    return resolve(name).factory(**params)
