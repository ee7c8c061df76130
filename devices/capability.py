"""Can these devices run that scenario? The capability check behind "refused with a clear message".

A scenario declares the tactile dimensions it is about (thesis Table 2.2; `Scenario.REQUIRES`,
any one suffices). Whether a device shows a dimension is decided by asking its cue encoder to
encode a probe cue of that dimension, so this check can never disagree with what the encoder
will do once the scenario runs (one owner for "what a profile can show").

A device shows nothing while it is not connected: given the devices' statuses (the device host's
reports), a device that is not `connected` is not usable, and a required dimension that some
configured device shows but no connected one does any more is *missing* (health names the device,
a trial that needs it is refused unless forced). A device whose status is not known yet (no report
so far) counts as connected.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

from server.core.cues import Friction, Stiffness, Temperature, Texture, Tilt
from devices.encoder import CueEncoder
from devices.profiles import DIMENSIONS, DeviceProfile, Display

PROBES = {"stiffness": Stiffness(), "macro_roughness": Tilt(), "fine_roughness": Texture(),
          "temperature": Temperature(), "friction": Friction()}
assert set(PROBES) == set(DIMENSIONS)
CONNECTED = "connected"  # the one device status that shows anything (devices/protocol.py)


def dimension_label(dimension: str) -> str:
    """A dimension as people read it: 'macro-roughness (tilt)'."""
    name, cue = dimension.replace("_", "-"), PROBES[dimension].kind.replace("_", " ")
    return name if cue == name else f"{name} ({cue})"


def connected(name: str, statuses: Mapping[str, str]) -> bool:
    return statuses.get(name, CONNECTED) == CONNECTED


def showing(requires: tuple[str, ...], profiles: Mapping[str, DeviceProfile]) -> dict[str, tuple[str, ...]]:
    """For each required dimension, the configured devices that show it (connected or not)."""
    return {d: tuple(name for name, profile in profiles.items() if shows(profile, d, name)[0]) for d in requires}


@dataclass(frozen=True)
class Missing:
    """A required dimension some configured device shows, and no connected one does."""
    dimension: str
    devices: tuple[str, ...]  # the devices that would show it, none of them connected
    statuses: tuple[str, ...]  # their statuses, in the same order

    def to_dict(self) -> dict:
        return {"dimension": self.dimension, "devices": list(self.devices), "statuses": list(self.statuses)}


CHECK_CABLE = "check its cable and power"


def device_advice(profile: DeviceProfile | None) -> str:
    """What a person does about a device that is not connected, by how the device is reached."""
    if profile is not None and profile.protocol == "browser":  # the participant's page (devices/browser.py)
        return "the participant's page offers no actuator (hold the controllers: tracked hands have none)"
    return CHECK_CABLE


def missing_device_text(scenario: str, dimension: str, device: str, status: str, advice: str = CHECK_CABLE) -> str:
    """One sentence a person can act on: which device, what is wrong, what the scenario loses."""
    return (f"device '{device}' is {status}: {advice}; the running scenario '{scenario}' "
            f"needs it for {dimension_label(dimension)}")


def missing(shown_by: Mapping[str, tuple[str, ...]], statuses: Mapping[str, str]) -> tuple[Missing, ...]:
    """The required dimensions (`showing`'s map) that no connected device shows any more. A
    dimension no configured device shows at all is not missing: the capability check refuses
    (or a forced run accepts) that scenario up front."""
    return tuple(Missing(d, names, tuple(statuses.get(n, CONNECTED) for n in names))
                 for d, names in shown_by.items() if names and not any(connected(n, statuses) for n in names))


def shows(profile: DeviceProfile, dimension: str, name: str | None = None) -> tuple[bool, str]:
    """(True, "direct" | "as vibration") or (False, the encoder's reason)."""
    encoding = CueEncoder(profile, name).encode((PROBES[dimension],))
    if encoding.refusals:
        return False, encoding.refusals[0].reason
    how = profile.dimensions[dimension]
    return True, "direct" if how is Display.DIRECT else "as vibration"


@dataclass(frozen=True)
class CapabilityReport:
    scenario: str
    requires: tuple[str, ...]
    ok: bool
    usable: tuple[str, ...]          # connected devices that show at least one required dimension
    message: str                     # one paragraph for people
    devices: tuple[dict, ...]        # per device: name, model, status, usable, per dimension: shown + how/why
    missing: tuple[Missing, ...] = ()  # required dimensions only disconnected devices show

    def to_dict(self) -> dict:
        return {"scenario": self.scenario, "requires": list(self.requires), "ok": self.ok, "usable": list(self.usable),
                "message": self.message, "devices": list(self.devices),
                "missing": [m.to_dict() for m in self.missing]}


def check(scenario: str, requires: tuple[str, ...], profiles: Mapping[str, DeviceProfile],
          statuses: Mapping[str, str] | None = None) -> CapabilityReport:
    """Refuse a scenario when devices are configured and no connected one shows any required
    dimension. `statuses`: each device's status (absent: not known yet, taken as connected).

    No device at all is allowed (visual-only runs, demos); a scenario that requires nothing
    (free exploration) runs anywhere."""
    statuses = statuses or {}
    rows, usable, reasons = [], [], []
    for name, profile in profiles.items():
        status = statuses.get(name, CONNECTED)
        row = {"name": name, "model": profile.model, "status": status, "usable": False, "dimensions": {}}
        for dimension in requires:
            ok, how = shows(profile, dimension, name)
            row["dimensions"][dimension] = {"shown": ok, "how" if ok else "reason": how}
            if ok and status != CONNECTED:
                reasons.append(f"{name} shows {dimension_label(dimension)} but is {status}.")
            elif ok and name not in usable:
                usable.append(name)
            elif not ok:
                reasons.append(how)
        row["usable"] = name in usable
        rows.append(row)
    wanted = " or ".join(d.replace("_", "-") for d in requires)
    if not requires:
        ok, message = True, f"{scenario} needs no tactile dimension"
    elif not profiles:
        ok, message = True, f"{scenario}: no tactile device configured; the scene runs visually only"
    elif usable:
        ok, message = True, f"{scenario} shows {wanted} on {', '.join(usable)}"
    else:
        ok = False
        message = (f"{scenario} is refused: it needs a device that shows {wanted}, and "
                   + ("no connected device does. " if any(not r["usable"] and r["status"] != CONNECTED for r in rows)
                      else "none of the configured devices does. ") + " ".join(reasons))
    gone = missing(showing(tuple(requires), profiles), statuses) if statuses else ()
    if ok and gone:
        message += "; " + "; ".join(f"{dimension_label(m.dimension)} is not shown: {', '.join(m.devices)} "
                                    f"{'is' if len(m.devices) == 1 else 'are'} not connected" for m in gone)
    return CapabilityReport(scenario, tuple(requires), ok, tuple(usable), message, tuple(rows), gone)
