"""Tracker source specifications (`viestac serve --tracker SPEC`, repeatable).

    leap[:URL]                      the Leap Motion service (default ws://127.0.0.1:6437/v6.json)
    replay:FILE.csv[:loop|:once]    a recorded trajectory (scene units; default: loop)
    scripted:NAME                   a scripted demo source (server/tracking/scripted.py)

Each source gets a name (its kind; `leap2`, `replay2`, ... for a second one of a kind), which
names its health entry, its calibration file and its REST routes. Pure.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from server.tracking import leap_frames, replay, scripted

LEAP_URL = "ws://127.0.0.1:6437/v6.json"


@dataclass(frozen=True)
class SourceSpec:
    name: str
    kind: str          # leap | replay | scripted
    target: str        # URL, file or script name
    loop: bool = True  # replay only
    nominal_hz: float = 120.0

    def to_dict(self) -> dict:
        return {"name": self.name, "kind": self.kind, "target": self.target, "loop": self.loop,
                "nominal_hz": self.nominal_hz}

    @classmethod
    def from_dict(cls, table: dict) -> "SourceSpec":
        return cls(**table)


def parse_spec(text: str, taken: set[str] | frozenset = frozenset()) -> SourceSpec:
    kind, _, rest = text.strip().partition(":")
    if kind == "leap":
        url = rest or LEAP_URL
        if not url.startswith(("ws://", "wss://")):
            raise ValueError(f"--tracker {text!r}: a Leap URL starts with ws:// (e.g. {LEAP_URL})")
        spec = SourceSpec("leap", "leap", url, nominal_hz=leap_frames.NOMINAL_HZ)
    elif kind == "replay":
        loop = True
        path = rest
        for suffix, value in ((":loop", True), (":once", False)):
            if rest.endswith(suffix):
                path, loop = rest[: -len(suffix)], value
        if not path:
            raise ValueError(f"--tracker {text!r}: expected replay:FILE.csv[:loop|:once]")
        track = replay.parse_csv(Path(path).read_text(), where=path)  # fails early, naming the line
        spec = SourceSpec("replay", "replay", path, loop=loop, nominal_hz=round(1.0 / track.period_s, 3))
    elif kind == "scripted":
        scripted.script(rest)
        spec = SourceSpec("scripted", "scripted", rest, nominal_hz=scripted.RATE_HZ)
    else:
        raise ValueError(f"--tracker {text!r}: expected leap[:URL], replay:FILE.csv[:loop|:once] or scripted:NAME")
    name, n = spec.name, 1
    while name in taken:
        n += 1
        name = f"{spec.name}{n}"
    return SourceSpec(name, spec.kind, spec.target, spec.loop, spec.nominal_hz)


def parse_specs(texts) -> tuple[SourceSpec, ...]:
    specs: list[SourceSpec] = []
    for text in texts:
        specs.append(parse_spec(text, {s.name for s in specs}))
    return tuple(specs)
