"""Browser actuators: the participant page's own actuators as a device (issue 37 point 4), sans-I/O.

A participant in a headset holds two actuators (WebXR `XRInputSource.gamepad.hapticActuators[0]
.pulse(value, ms)`), a desktop gamepad rumbles (Gamepad API `vibrationActuator.playEffect(
"dual-rumble", {duration, strongMagnitude, weakMagnitude})`). Both take an amplitude (0..1) and a
duration, nothing else, and the page can only call them once per rendered frame. The `browser`
profile (devices/profiles.py BROWSER) says so, and this encoder refuses the rest with a reason:

- no carrier frequency: a cue that names one is refused (`no_capability`);
- no tilt direction: a tilt is shown as its magnitude (macro-roughness "(!)", as on any vibrator);
- no texture period (fine roughness `-`), no temperature, no friction: refused by the profile;
- at most `MAX_EFFECT_MS` an effect: a timed stimulus longer than that is refused (`out_of_range`);
- tracked hands have no actuator: a page whose hands are tracked offers none (the device is then
  `disconnected`, and the page says why).

The hub (server/hub/browser_actuators.py) is the device's host: it encodes the primary tool's cues
of each state record into a `Drive` and puts it in that state frame (`state.actuator`, docs/protocol.md),
so the pulse and the picture of a tick reach the page together and the page plays the newest drive
in every frame it renders (clients/web/src/actuators.js).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from server.core.cues import Cue, PulseTrain, Vibration
from server.core.points import PRIMARY_POINT
from devices.encoder import CueEncoder, Refusal
from devices.messages import PatternMode
from devices.profiles import BROWSER, DeviceProfile

# Chromium ends a `playEffect` whose duration exceeds 5 s with "invalid-parameter" (the Gamepad
# API extension's dual-rumble effect is capped at 5000 ms); WebXR's `pulse` has no stated cap, and
# one limit for both keeps the profile one promise.
MAX_EFFECT_MS = 5000.0


class BrowserConfigError(ValueError):
    pass


@dataclass(frozen=True)
class Drive:
    """What the page plays from the tick `onset` on: `value` (0..1; 0 = off) continuously
    (`off_ms` 0) or `on_ms` on, `off_ms` off, repeated; for `duration_ms` (0: until the next drive)."""
    value: float
    on_ms: float
    off_ms: float
    duration_ms: float
    onset: int

    def to_wire(self) -> list:
        return [self.value, self.on_ms, self.off_ms, self.duration_ms, self.onset]

    def same_pattern(self, other: Drive | None) -> bool:
        return other is not None and (self.value, self.on_ms, self.off_ms, self.duration_ms) == \
            (other.value, other.on_ms, other.off_ms, other.duration_ms)


@dataclass(frozen=True)
class BrowserEncoding:
    drive: Drive
    refusals: tuple[Refusal, ...]


class BrowserEncoder:
    """The cue encoder (devices/encoder.py) for the browser profile, plus the limits only a
    browser has (a carrier, an effect's length), and the pattern command as a Drive."""

    def __init__(self, profile: DeviceProfile = BROWSER, device: str = "browser"):
        self.encoder = CueEncoder(profile, device)

    def _limit(self, cue: Cue) -> Refusal | None:
        if isinstance(cue, (Vibration, PulseTrain)):
            if cue.carrier_hz is not None:
                return self.encoder._refuse(cue, "no_capability", f"a browser actuator sets amplitude and duration "
                                            f"only, not a carrier frequency ({cue.carrier_hz:g} Hz asked)")
            if cue.duration_ms is not None and cue.duration_ms > MAX_EFFECT_MS:
                return self.encoder._refuse(cue, "out_of_range", f"a browser effect lasts at most "
                                            f"{MAX_EFFECT_MS / 1000:g} s ({cue.duration_ms:g} ms asked)")
        return None

    def encode(self, cues: Iterable[Cue], tick: int) -> BrowserEncoding:
        cues = tuple(cues)
        limits = [(cue, self._limit(cue)) for cue in cues]
        shown = tuple(cue for cue, refusal in limits if refusal is None)
        encoding = self.encoder.encode(shown)
        refusals = tuple(r for _, r in limits if r is not None) + encoding.refusals
        pattern = encoding.commands.get("pattern")
        refused = {r.cue for r in encoding.refusals}
        timed = next((c.duration_ms for c in shown if isinstance(c, (Vibration, PulseTrain))
                      and c.kind not in refused and c.duration_ms is not None), None)
        if pattern is None or pattern.mode == PatternMode.OFF or pattern.intensity == 0:
            return BrowserEncoding(Drive(0.0, 0.0, 0.0, 0.0, tick), refusals)
        pulsed = pattern.mode == PatternMode.PULSE and pattern.off_us > 0
        return BrowserEncoding(Drive(pattern.intensity / 100.0, pattern.on_ms if pulsed else 0.0,
                                     pattern.off_ms if pulsed else 0.0, float(timed or 0.0), tick), refusals)


def check_configs(configs: Iterable) -> None:
    """A rig has at most one browser device, on the primary point: the state frame carries the
    primary tool's cues, and every participant page that offers actuators is that one device."""
    browser = [c for c in configs if c.profile.protocol == "browser"]
    if len(browser) > 1:
        raise BrowserConfigError(f"at most one browser device a rig (the participant's page): "
                                 f"{', '.join(c.name for c in browser)}")
    for c in browser:
        if c.finger != PRIMARY_POINT:
            raise BrowserConfigError(f"device {c.name}: a browser actuator follows the primary point's cues "
                                     f"({PRIMARY_POINT}), not {c.finger}")
