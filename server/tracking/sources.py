"""Tracker source specifications (`viestac serve --tracker SPEC`, repeatable), and the kinds of
source: one module each, declaring its SourceKind (server/tracking/source_kind.py), listed below.

    leap[:URL]                      the Leap Motion service (default ws://127.0.0.1:6437/v6.json)
    replay:FILE.csv[:loop|:once]    a recorded trajectory (scene units; default: loop)
    scripted:NAME                   a scripted demo source (server/tracking/scripted.py)

Each source gets a name (its kind; `leap2`, `replay2`, ... for a second one of a kind), which
names its health entry, its calibration file and its REST routes.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Mapping

from server.tracking import leap_source, replay_source, scripted_source
from server.tracking.source_kind import SourceKind, SourceSpec

__all__ = ["KINDS", "LEAP_URL", "SourceKind", "SourceSpec", "parse_spec", "parse_specs"]

LEAP_URL = leap_source.LEAP_URL

# The whole list, explicit (no registration by import side effect): a new kind is a module with
# its KIND and one entry here.
KINDS: Mapping[str, SourceKind] = MappingProxyType({k.name: k for k in (
    leap_source.KIND, replay_source.KIND, scripted_source.KIND,
)})


def parse_spec(text: str, taken: set[str] | frozenset = frozenset(),
               kinds: Mapping[str, SourceKind] | None = None) -> SourceSpec:
    kinds = KINDS if kinds is None else kinds
    name, _, rest = text.strip().partition(":")
    kind = kinds.get(name)
    if kind is None:
        usages = [k.usage for k in kinds.values()]
        raise ValueError(f"--tracker {text!r}: expected {', '.join(usages[:-1])} or {usages[-1]}")
    spec = kind.parse(rest, text)
    name, n = spec.name, 1
    while name in taken:
        n += 1
        name = f"{spec.name}{n}"
    return SourceSpec(name, spec.kind, spec.target, spec.loop, spec.nominal_hz)


def parse_specs(texts, kinds: Mapping[str, SourceKind] | None = None) -> tuple[SourceSpec, ...]:
    specs: list[SourceSpec] = []
    for text in texts:
        specs.append(parse_spec(text, {s.name for s in specs}, kinds))
    return tuple(specs)
