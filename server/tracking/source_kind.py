"""What a tracker source is, declared once: its spec (`viestac serve --tracker KIND[:REST]`, parsed
in the hub, sent to the tracker host as JSON) and the interface every kind of source implements
(server/tracking/sources.py lists the kinds; docs/architecture.md "How to add things")."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Awaitable, Callable, Protocol

from server.tracking.calibration import Calibration
from server.tracking.health import SourceHealth


@dataclass(frozen=True)
class SourceSpec:
    name: str
    kind: str          # a key of server/tracking/sources.py KINDS: leap | replay | scripted
    target: str        # URL, file or script name
    loop: bool = True  # replay only
    nominal_hz: float = 120.0

    def to_dict(self) -> dict:
        return {"name": self.name, "kind": self.kind, "target": self.target, "loop": self.loop,
                "nominal_hz": self.nominal_hz}

    @classmethod
    def from_dict(cls, table: dict) -> "SourceSpec":
        return cls(**table)


class Feed(Protocol):
    """What a running source feeds (the tracker host's Source, server/tracking/tracker_host_process.py)."""
    spec: SourceSpec
    health: SourceHealth  # a runner sets its `note` and `connected`
    pipeline: Any         # server/tracking/pipeline.py SourcePipeline (reset_filters on a new track)

    def sample(self, raw_points: dict, t_s: float, confidence: float) -> None:
        """One sample of raw points (the kind's own units and axes; calibrated downstream)."""


@dataclass(frozen=True)
class SourceKind:
    """One kind of tracker source."""
    name: str                                  # the KIND of --tracker KIND[:REST]
    usage: str                                 # its --tracker syntax, for the error message
    parse: Callable[[str, str], SourceSpec]    # (REST, the whole text) → its spec (named `name`); ValueError
    run: Callable[[Feed], Awaitable[None]]     # the tracker host awaits it: feed samples until the source ends
    filtered: bool = True                      # 1€-filter its points (a script's are exact)
    calibration: Callable[[], Calibration] = Calibration  # its calibration until one is stored
