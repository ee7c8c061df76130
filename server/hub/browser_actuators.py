"""The rig's browser device: the participant pages' own actuators (WebXR controllers, gamepads), with
the hub as its host (issue 37 point 4; devices/browser.py is the encoder, docs/devices.md "Browser
actuators").

I/O-free, owned by the event loop's thread like the rest of the hub. A page tells what it can drive
in an `actuators` message (v1.6); the device is `connected` while at least one page offers an
actuator, else `disconnected` with the pages' reasons (tracked hands have none). The cues reach the
pages inside the state frames: for every state record the hub encodes the primary tool's cues for
the browser profile (only when they changed: a memo on the view's cue list) and the state frame
carries the result as `actuator` (`[value, on_ms, off_ms, duration_ms, onset]`), so the pulse and the
picture of a tick travel together through the same latest-wins slot.
"""

from __future__ import annotations

import logging
from typing import Callable

from devices.browser import BrowserEncoder, Drive
from devices.encoder import Refusal
from devices.manager import DeviceConfig
from server.core.cues import cue_from_wire

log = logging.getLogger("viestac.devices")

CONNECTED, DISCONNECTED = "connected", "disconnected"
MAX_ACTUATORS = 16  # a page's offer is cut to this many (a headset has two, a desk a gamepad or four)


class BrowserActuators:
    """`on_change()`: called when the device's status or refusals changed (the loop link reports them)."""

    def __init__(self, on_change: Callable[[], None] = lambda: None):
        self.on_change = on_change
        self.config: DeviceConfig | None = None
        self.encoder: BrowserEncoder | None = None
        self.offers: dict[int, tuple[tuple[tuple[str, str], ...], str]] = {}  # client id → (actuators, note)
        self._cues: list | None = None  # the view's cue list last encoded
        self.drive: Drive | None = None
        self.refusals: tuple[Refusal, ...] = ()
        self.connects = 0
        self.disconnects = 0

    def configure(self, config: DeviceConfig | None) -> None:
        """The rig's browser device (at most one, devices/browser.py check_configs), or None."""
        self.config = config
        self.encoder = BrowserEncoder(config.profile, config.name) if config is not None else None

    @property
    def name(self) -> str | None:
        return self.config.name if self.config is not None else None

    def profiles(self) -> dict:
        return {self.config.name: self.config.profile} if self.config is not None else {}

    def status(self) -> str:
        return CONNECTED if any(actuators for actuators, _ in self.offers.values()) else DISCONNECTED

    def statuses(self) -> dict[str, str]:
        return {self.config.name: self.status()} if self.config is not None else {}

    def offer(self, client_id: int, actuators: tuple[tuple[str, str], ...], note: str, *, left: bool = False) -> None:
        """A page's `actuators` message; `left`: the page's connection closed (its offer goes)."""
        before = self.status()
        if left:
            self.offers.pop(client_id, None)
        else:
            self.offers[client_id] = (tuple(actuators[:MAX_ACTUATORS]), note)
        after = self.status()
        if self.config is not None and after != before:
            if after == CONNECTED:
                self.connects += 1
            else:
                self.disconnects += 1
            log.info("browser device %s: %s (%s)", self.config.name, after, self.describe())
            self.on_change()

    def describe(self) -> str:
        """The pages' actuators for people: 'client 3: xr right, xr left' or the reason there are none."""
        parts = []
        for client_id, (actuators, note) in sorted(self.offers.items()):
            what = ", ".join(f"{kind} {hand}" if hand != "none" else kind for kind, hand in actuators)
            parts.append(f"client {client_id}: {what or note or 'no actuator'}")
        return "; ".join(parts) or "no participant page offers an actuator"

    def state_field(self, view: dict) -> list | None:
        """The state frame's `actuator` for this state record's view (None: no browser device)."""
        if self.encoder is None:
            return None
        cues = view["cues"]
        if cues != self._cues or self.drive is None:
            self._cues = cues
            try:
                encoding = self.encoder.encode((cue_from_wire(c) for c in cues), view["tick"])
            except ValueError as exc:  # the loop checked them; a bad one must still not stop the frames
                log.warning("browser device: a cue it cannot read: %s", exc)
                return self.drive.to_wire() if self.drive is not None else None
            # the same pattern again keeps its onset: the page does not restart a pulse train
            if not encoding.drive.same_pattern(self.drive):
                self.drive = encoding.drive
            if encoding.refusals != self.refusals:
                for r in encoding.refusals:
                    if r not in self.refusals:
                        log.warning("refused: %s", r.reason)
                self.refusals = encoding.refusals
                self.on_change()  # the rig's report (a browser-only rig's refusals are the scenario's HUD)
        return self.drive.to_wire()

    def snapshot(self) -> dict | None:
        """The device as GET /api/devices lists it (the serial devices' row shape where it applies)."""
        if self.config is None:
            return None
        status = self.status()
        return {"name": self.config.name, "port": self.config.where, "path": None, "status": status,
                "identity": None, "rtt_ms": None, "counters": {}, "connects": self.connects,
                "disconnects": self.disconnects, "last_error": None if status == CONNECTED else self.describe(),
                "last_error_at": None, "warning": None, "events": [],
                "pages": [{"client_id": cid, "actuators": [list(a) for a in actuators], "note": note}
                          for cid, (actuators, note) in sorted(self.offers.items())],
                "drive": self.drive.to_wire() if self.drive is not None else None,
                "profile": self.config.profile.to_dict(), "finger": self.config.finger,
                "refusals": [r.to_dict() for r in self.refusals]}
