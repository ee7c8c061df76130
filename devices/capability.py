"""Can these devices run that scenario? The capability check behind "refused with a clear message".

A scenario declares the tactile dimensions it is about (thesis Table 2.2; `Scenario.REQUIRES`,
any one suffices). Whether a device shows a dimension is decided by asking its cue encoder to
encode a probe cue of that dimension, so this check can never disagree with what the encoder
will do once the scenario runs (one owner for "what a profile can show").
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
    usable: tuple[str, ...]          # devices that show at least one required dimension
    message: str                     # one paragraph for people
    devices: tuple[dict, ...]        # per device: name, model, per dimension: shown + how/why

    def to_dict(self) -> dict:
        return {"scenario": self.scenario, "requires": list(self.requires), "ok": self.ok, "usable": list(self.usable),
                "message": self.message, "devices": list(self.devices)}


def check(scenario: str, requires: tuple[str, ...], profiles: Mapping[str, DeviceProfile]) -> CapabilityReport:
    """Refuse a scenario when devices are configured and none shows any required dimension.

    No device at all is allowed (visual-only runs, demos); a scenario that requires nothing
    (free exploration) runs anywhere."""
    rows, usable, reasons = [], [], []
    for name, profile in profiles.items():
        row = {"name": name, "model": profile.model, "dimensions": {}}
        for dimension in requires:
            ok, how = shows(profile, dimension, name)
            row["dimensions"][dimension] = {"shown": ok, "how" if ok else "reason": how}
            if ok and name not in usable:
                usable.append(name)
            elif not ok:
                reasons.append(how)
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
        message = (f"{scenario} is refused: it needs a device that shows {wanted}, and none of the configured "
                   f"devices does. " + " ".join(reasons))
    return CapabilityReport(scenario, tuple(requires), ok, tuple(usable), message, tuple(rows))
