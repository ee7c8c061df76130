"""Device profiles: what a tactile device can show, declared once, used by the cue encoder.

A profile names the device (model, firmware, channels, carrier) and, for each of the five
tactile dimensions of thesis Table 2.2 (stiffness, macro-roughness, fine roughness, temperature,
friction), whether the device shows it directly, encodes it as vibration ("(!)" in the table),
or not at all. `caps` are the commands its firmware accepts (device-protocol.md §3 caps bits).
Scenarios never see profiles: they emit cues, and `devices.encoder` turns cues into commands
for a profile or refuses them with a reason. Adding a device = adding a profile (or a TOML file).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from enum import Enum
from types import MappingProxyType

from devices.messages import CAP_NAMES


class Display(str, Enum):
    DIRECT = "direct"        # Table 2.2 "!"
    VIBRATION = "vibration"  # Table 2.2 "(!)": encoded as vibration
    NONE = "none"            # not shown

    @property
    def mark(self) -> str:
        return {"direct": "!", "vibration": "(!)", "none": "-"}[self.value]


DIMENSIONS = ("stiffness", "macro_roughness", "fine_roughness", "temperature", "friction")
CAPS = CAP_NAMES  # the commands a firmware may accept (IDENTIFY caps bits, device-protocol.md §3)
# Dimensions with a defined vibration encoding (devices/encoder.py). Temperature and friction
# have none that means anything, so a profile may not claim them as "(!)".
VIBRATION_ENCODABLE = frozenset({"stiffness", "macro_roughness", "fine_roughness"})
# The command a DIRECT dimension needs.
DIRECT_CAP = {"macro_roughness": "tilt", "fine_roughness": "texture", "temperature": "temperature",
              "friction": "friction"}


# binary: device-protocol.md; line: ASCII templates (devices/line_protocol.py); audio: channels of a
# sound interface (devices/audio/), configured by a rig file's [device.audio] table; browser: the
# participant page's own actuators (WebXR controllers, gamepads: devices/browser.py), driven over /ws
PROTOCOLS = ("binary", "line", "audio", "browser")


class ProfileError(ValueError):
    pass


@dataclass(frozen=True)
class DeviceProfile:
    model: str                       # lower-case id, as the firmware reports it in IDENTIFY
    title: str
    firmware: str                    # firmware version this profile was written for
    channels: tuple[str, ...]        # actuator names, channel i = channels[i]
    carrier_hz: int                  # default vibration carrier (0 = none)
    caps: frozenset[str]
    dimensions: Mapping[str, Display]
    protocol: str = "binary"         # "binary" (device-protocol.md), "line" (ASCII templates) or "audio"
    line: Mapping[str, str] = field(default_factory=dict)  # line-protocol templates
    notes: str = ""

    def __post_init__(self) -> None:
        if not self.model or not self.model.isascii() or self.model != self.model.lower() or len(self.model) > 32:
            raise ProfileError(f"model must be 1..32 lower-case ASCII characters, got {self.model!r}")
        if not self.channels:
            raise ProfileError(f"{self.model}: at least one channel")
        unknown = set(self.caps) - set(CAPS)
        if unknown:
            raise ProfileError(f"{self.model}: unknown caps {sorted(unknown)}; known: {', '.join(CAPS)}")
        dims = {k: Display(v) for k, v in self.dimensions.items()}
        missing, extra = set(DIMENSIONS) - set(dims), set(dims) - set(DIMENSIONS)
        if missing or extra:
            raise ProfileError(f"{self.model}: dimensions must be exactly {', '.join(DIMENSIONS)}"
                               f" (missing {sorted(missing)}, unknown {sorted(extra)})")
        for dim, how in dims.items():
            if how is Display.VIBRATION:
                if dim not in VIBRATION_ENCODABLE:
                    raise ProfileError(f"{self.model}: {dim} has no vibration encoding; say direct or none")
                if not {"pulse", "continuous"} & self.caps:
                    raise ProfileError(f"{self.model}: {dim} encoded as vibration needs the pulse or continuous cap")
            if how is Display.DIRECT and dim in DIRECT_CAP and DIRECT_CAP[dim] not in self.caps:
                raise ProfileError(f"{self.model}: {dim} shown directly needs the {DIRECT_CAP[dim]!r} cap")
        if self.protocol not in PROTOCOLS:
            raise ProfileError(f"{self.model}: protocol must be one of {', '.join(PROTOCOLS)}, got {self.protocol!r}")
        if self.protocol == "audio" and not {"pulse", "continuous", "texture"} >= set(self.caps):
            raise ProfileError(f"{self.model}: an audio channel plays pulse, continuous and texture patterns only")
        if self.protocol == "browser" and not {"pulse", "continuous"} >= set(self.caps):
            raise ProfileError(f"{self.model}: a browser actuator plays pulse and continuous patterns only")
        if self.protocol == "line":
            self._check_line_templates()
        object.__setattr__(self, "caps", frozenset(self.caps))
        object.__setattr__(self, "dimensions", MappingProxyType(dims))
        object.__setattr__(self, "line", MappingProxyType(dict(self.line)))

    def _check_line_templates(self) -> None:
        from devices.line_protocol import LineProfile  # only line profiles need it

        if not self.line:
            raise ProfileError(f"{self.model}: a line-protocol profile needs [line] templates")
        try:
            LineProfile.from_dict(self.line, where=f"{self.model} line")
        except ValueError as exc:
            raise ProfileError(str(exc)) from None
        # Every command the profile claims needs its line, and a pattern needs a way to stop.
        needed = set(self.caps) | ({"off"} if {"pulse", "continuous", "texture"} & self.caps else set())
        missing = sorted(needed - set(self.line))
        if missing:
            raise ProfileError(f"{self.model}: caps need line templates for {', '.join(missing)}")

    def table_row(self) -> dict[str, str]:
        """Thesis Table 2.2 notation: '!' direct, '(!)' encoded as vibration, '-' not shown."""
        return {dim: self.dimensions[dim].mark for dim in DIMENSIONS}

    def with_identity(self, *, channels: int, caps: frozenset[str], carrier_hz: int, firmware: str) -> DeviceProfile:
        """The profile corrected by what the device reported in IDENTIFY (the device knows best):
        a dimension whose command the device lacks drops to NONE."""
        names = tuple(self.channels[i] if i < len(self.channels) else f"ch{i}" for i in range(channels))
        dims = dict(self.dimensions)
        for dim, how in dims.items():
            if how is Display.DIRECT and dim in DIRECT_CAP and DIRECT_CAP[dim] not in caps:
                dims[dim] = Display.NONE
            if how is Display.VIBRATION and not {"pulse", "continuous"} & caps:
                dims[dim] = Display.NONE
        return replace(self, channels=names, caps=caps, carrier_hz=carrier_hz, firmware=firmware, dimensions=dims)

    def to_dict(self) -> dict:
        return {"model": self.model, "title": self.title, "firmware": self.firmware, "protocol": self.protocol,
                "channels": list(self.channels), "carrier_hz": self.carrier_hz, "caps": sorted(self.caps),
                "dimensions": {d: self.dimensions[d].value for d in DIMENSIONS}, "table_2_2": self.table_row()}

    def to_table(self) -> dict:
        """The profile as a table `from_dict` reads back (to_dict is the console's view)."""
        return {"model": self.model, "title": self.title, "firmware": self.firmware, "channels": list(self.channels),
                "carrier_hz": self.carrier_hz, "caps": sorted(self.caps),
                "dimensions": {d: how.value for d, how in self.dimensions.items()}, "protocol": self.protocol,
                "line": dict(self.line), "notes": self.notes}

    def __reduce__(self):
        # the read-only mappings do not pickle; the device host process gets its configs pickled
        return (_profile_from_table, (self.to_table(),))

    @classmethod
    def from_dict(cls, data: Mapping, *, where: str = "profile") -> DeviceProfile:
        """A profile from a TOML/JSON table (see docs/devices.md); ProfileError names the bad key."""
        allowed = {"model", "title", "firmware", "channels", "carrier_hz", "caps", "dimensions", "protocol", "line", "notes"}
        unknown = set(data) - allowed
        if unknown:
            raise ProfileError(f"{where}: unknown key(s) {sorted(unknown)}; allowed: {', '.join(sorted(allowed))}")
        for key in ("model", "channels", "caps", "dimensions"):
            if key not in data:
                raise ProfileError(f"{where}: missing key {key!r}")
        try:
            return cls(model=str(data["model"]), title=str(data.get("title", data["model"])),
                       firmware=str(data.get("firmware", "")), channels=tuple(str(c) for c in data["channels"]),
                       carrier_hz=int(data.get("carrier_hz", 0)), caps=frozenset(data["caps"]),
                       dimensions=dict(data["dimensions"]), protocol=str(data.get("protocol", "binary")),
                       line=dict(data.get("line", {})), notes=str(data.get("notes", "")))
        except ProfileError as exc:
            raise ProfileError(f"{where}: {exc}") from None
        except (TypeError, ValueError) as exc:
            raise ProfileError(f"{where}: {exc}") from None


def _profile_from_table(table: dict) -> DeviceProfile:
    return DeviceProfile.from_dict(table)


FINGERTAC = DeviceProfile(
    model="fingertac", title="FingerTac (DLR): two LRAs beside the fingerpad", firmware="1.0.0",
    channels=("lra_left", "lra_right"), carrier_hz=235, caps=frozenset({"pulse", "continuous", "texture"}),
    dimensions={"stiffness": "vibration", "macro_roughness": "none", "fine_roughness": "vibration",
                "temperature": "none", "friction": "none"},
    notes="1-DoF: both LRAs vibrate together at their 235 Hz resonance; cues are PWM bursts (thesis §3.1).")

FERROVIBE = DeviceProfile(
    model="ferrovibe", title="FerroVibe (DLR): magnet in ferrofluid tilted by two solenoids", firmware="1.0.0",
    channels=("magnet",), carrier_hz=235, caps=frozenset({"pulse", "continuous", "texture", "tilt"}),
    dimensions={"stiffness": "vibration", "macro_roughness": "direct", "fine_roughness": "direct",
                "temperature": "none", "friction": "none"},
    notes="Tilt direction 0 = front, 90 = right, 180 = back, 270 = left; texture by re-tilting (thesis §3.2).")

DEVKIT = DeviceProfile(
    model="devkit",
    title="ViESTac devkit: reference firmware for new devices — one vibrotactile actuator (LRA, 235 Hz carrier), "
          "a Peltier element and a friction display on one fingertip",
    firmware="1.0.0", channels=("fingertip",), carrier_hz=235,
    caps=frozenset({"pulse", "continuous", "texture", "temperature", "friction"}),
    dimensions={"stiffness": "vibration", "macro_roughness": "none", "fine_roughness": "direct",
                "temperature": "direct", "friction": "direct"},
    notes="Every layer but tilt on one channel; the reference sketch (devices/firmware/devkit) drives the "
          "Peltier open loop, a real build closes it on a thermistor.")

AUDIO = DeviceProfile(
    model="audio",
    title="Voice-coil tactor on a sound interface channel (EAI C2/C3, Tactile Labs Haptuator, an LRA behind an "
          "amplifier)",
    firmware="", channels=("coil",), carrier_hz=250, caps=frozenset({"pulse", "continuous", "texture"}),
    dimensions={"stiffness": "vibration", "macro_roughness": "none", "fine_roughness": "direct",
                "temperature": "none", "friction": "none"},
    protocol="audio",
    notes="A broadband actuator: any carrier in its channel's frequency range, textures as their own waveform; "
          "no tilt. The [device.audio] table of a rig file names the output and the channels (docs/devices.md).")

BROWSER = DeviceProfile(
    model="browser",
    title="The participant page's actuators: a WebXR controller's haptic actuator or a gamepad's rumble",
    firmware="", channels=("actuator",), carrier_hz=0, caps=frozenset({"pulse", "continuous"}),
    dimensions={"stiffness": "vibration", "macro_roughness": "vibration", "fine_roughness": "none",
                "temperature": "none", "friction": "none"},
    protocol="browser",
    notes="Amplitude and duration only: no carrier frequency, no tilt direction (a tilt is its magnitude), no "
          "texture period, no temperature; at most 5 s an effect; updated once per rendered frame; tracked hands "
          "have none (devices/browser.py).")

# The built-in devices that run the firmware core (devices/firmware: one vt_model each) ...
PROFILES: Mapping[str, DeviceProfile] = MappingProxyType({p.model: p for p in (FINGERTAC, FERROVIBE, DEVKIT)})
# ... and those that run none of ours: a sound interface's channels (devices/audio/)
AUDIO_PROFILES: Mapping[str, DeviceProfile] = MappingProxyType({AUDIO.model: AUDIO})
# ... and the participant page's own actuators, driven by the hub over /ws (devices/browser.py)
BROWSER_PROFILES: Mapping[str, DeviceProfile] = MappingProxyType({BROWSER.model: BROWSER})


def profile_by_model(model: str) -> DeviceProfile:
    found = PROFILES.get(model) or AUDIO_PROFILES.get(model) or BROWSER_PROFILES.get(model)
    if found is None:
        raise ProfileError(f"no built-in profile {model!r}; built-in: "
                           f"{', '.join([*PROFILES, *AUDIO_PROFILES, *BROWSER_PROFILES])}"
                           " (or describe the device in a devices TOML file, docs/devices.md)")
    return found
