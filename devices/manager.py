"""DeviceManager: the configured devices of a rig, fed with the loop's cues.

It lives in the device host process (devices/device_host_process.py), where the device feed
(devices/feed.py) hands it each cue set the loop sends on the cue channel in every tick whose
cues changed. For every device it encodes the cues for that device's profile (devices.encoder)
and passes the commands to its SerialDevice, which coalesces them onto the link. Refusals (cues a
profile cannot show) are kept as the rig's current refusal set, logged when they appear, and
announced to listeners (the device host reports them to the hub, which passes them on to the
loop's scenario).

Configuration: `DeviceConfig.parse("ferrovibe@/dev/ttyUSB0")` for the command line, or a TOML
file with [[device]] tables (docs/devices.md), which may also describe a device of its own.

Several fingers: each device sits on one tracked point (`finger`, default the primary point
"right.index.tip"). The loop's cue set is the primary tool's; with several tools it also sends the
other tools' cues by name (`finger_cues`), and each device gets its own finger's cues only.
"""

from __future__ import annotations

import logging
import re
import threading
import time
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import serial

from server.core.cues import Cue
from server.core.points import PRIMARY_POINT, check_point_name
from devices.audio.config import AudioConfig, AudioConfigError
from devices.audio.mapping import AudioCueEncoder
from devices.audio.device import AudioDevice, UnderrunsCounted
from devices.browser import BrowserConfigError, check_configs as check_browser_configs
from devices.encoder import CueEncoder, Refusal
from devices.line_protocol import CommandRefused, DeviceLine, LineProtocol
from devices.link import BYTE_TIME_S
from devices.ports import PortSpec
from devices.messages import cap_names
from devices.profiles import DeviceProfile, ProfileError, profile_by_model
from devices.protocol import (WATCHDOG_MS, DeviceErrorReported, FrameRejected, DeviceSession, Identified, StatusChanged,
                              WatchdogReported)
from devices.serial_port import SerialDevice

log = logging.getLogger("viestac.devices")
_NAME = re.compile(r"^[a-z0-9][a-z0-9_-]{0,31}$")


class DeviceConfigError(ValueError):
    pass


@dataclass(frozen=True)
class DeviceConfig:
    name: str
    profile: DeviceProfile
    port: PortSpec | None  # None for an audio device (`audio` names its output instead)
    baud: int = 115200
    link_share: float = 0.5
    watchdog_ms: int = WATCHDOG_MS  # the firmware's own fail-safe (docs/device-protocol.md §2); 0 = off
    finger: str = PRIMARY_POINT  # the tracked point the device sits on: it gets that tool's cues only
    audio: AudioConfig | None = None  # a sound interface's channels (devices/audio/config.py)

    def __post_init__(self) -> None:
        if not _NAME.match(self.name):
            raise DeviceConfigError(f"device name {self.name!r}: 1-32 characters a-z 0-9 _ -, starting with a letter or digit")
        if (self.profile.protocol == "audio") != (self.audio is not None):
            raise DeviceConfigError(f"device {self.name}: an audio profile goes with an [device.audio] table, and "
                                    "only an audio profile")
        if (self.port is None) != (self.audio is not None or self.profile.protocol == "browser"):
            raise DeviceConfigError(f"device {self.name}: a serial device needs a port, an audio or browser device none")
        try:
            check_point_name(self.finger)
        except ValueError as exc:
            raise DeviceConfigError(f"device {self.name}: finger: {exc}") from None
        if not 1200 <= self.baud <= 4_000_000:
            raise DeviceConfigError(f"device {self.name}: baud {self.baud} out of range")
        if not 0 < self.link_share <= 1:
            raise DeviceConfigError(f"device {self.name}: link_share must be in (0, 1], got {self.link_share}")
        if not (self.watchdog_ms == 0 or 20 <= self.watchdog_ms <= 60_000):  # 20: room for keepalives
            raise DeviceConfigError(f"device {self.name}: watchdog_ms must be 0 (off) or 20..60000, got {self.watchdog_ms}")

    @property
    def where(self) -> str:
        """Where the device is reached: its port, its audio output (audio:NAME@HOST_API), or the
        participant's page (a browser actuator)."""
        if self.port is None and self.audio is None:
            return "browser:/ws"
        return str(self.port) if self.port is not None else self.audio.describe()

    @classmethod
    def parse(cls, text: str) -> DeviceConfig:
        """`[NAME=]MODEL@PORT`, e.g. `ferrovibe@/dev/ttyUSB0` or `left=fingertac@usb:303a:1001:A1`."""
        head, at, port = text.partition("@")
        name, _, model = head.rpartition("=")
        if not at or not model or not port:
            raise DeviceConfigError(f"device {text!r}: expected [NAME=]MODEL@PORT, e.g. ferrovibe@/dev/ttyUSB0")
        try:
            profile = profile_by_model(model)
            if profile.protocol == "audio":
                raise DeviceConfigError("an audio device is described in a rig file ([device.audio], docs/devices.md)")
            if profile.protocol == "browser":
                raise DeviceConfigError("a browser actuator has no port: `serve --rig ...,browser` or a rig file's "
                                        "[[device]] with profile = \"browser\" (docs/devices.md)")
            return cls(name=name or model, profile=profile, port=PortSpec.parse(port))
        except (ProfileError, ValueError) as exc:
            raise DeviceConfigError(f"device {text!r}: {exc}") from None

    @classmethod
    def from_dict(cls, data: Mapping, where: str) -> DeviceConfig:
        allowed = {"name", "profile", "port", "usb", "baud", "link_share", "watchdog_ms", "finger", "audio"}
        unknown = set(data) - allowed
        if unknown:
            raise DeviceConfigError(f"{where}: unknown key(s) {sorted(unknown)}; allowed: {', '.join(sorted(allowed))}")
        if "profile" not in data:
            raise DeviceConfigError(f"{where}: missing 'profile' (a built-in model name or a [profile] table)")
        try:
            raw = data["profile"]
            profile = profile_by_model(raw) if isinstance(raw, str) else DeviceProfile.from_dict(raw, where=f"{where}.profile")
            if "audio" in data:  # the channels are the actuators of the audio table
                audio = AudioConfig.from_dict(data["audio"], f"{where}.audio")
                if set(data) & {"port", "usb", "baud", "link_share", "watchdog_ms"}:
                    raise DeviceConfigError(f"{where}: an audio device has no port, usb, baud, link_share or watchdog_ms")
                return cls(name=str(data.get("name", profile.model)), profile=replace(profile, channels=audio.actuators),
                           port=None, audio=audio, finger=str(data.get("finger", PRIMARY_POINT)))
            if profile.protocol == "browser":  # the participant's page: reached over /ws, not a port
                if set(data) - {"name", "profile", "finger"}:
                    raise DeviceConfigError(f"{where}: a browser device has only name, profile and finger")
                return cls(name=str(data.get("name", profile.model)), profile=profile, port=None,
                           finger=str(data.get("finger", PRIMARY_POINT)))
            return cls(name=str(data.get("name", profile.model)), profile=profile, port=PortSpec.from_dict(data),
                       baud=int(data.get("baud", 115200)), link_share=float(data.get("link_share", 0.5)),
                       watchdog_ms=int(data.get("watchdog_ms", WATCHDOG_MS)),
                       finger=str(data.get("finger", PRIMARY_POINT)))
        except (DeviceConfigError, ProfileError, AudioConfigError) as exc:  # already name where they come from
            raise DeviceConfigError(str(exc)) from None
        except (ValueError, TypeError) as exc:
            raise DeviceConfigError(f"{where}: {exc}") from None


def load_device_file(path: str | Path) -> list[DeviceConfig]:
    """[[device]] tables from a TOML file; DeviceConfigError names the file, table and key."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except OSError as exc:
        raise DeviceConfigError(f"{path}: {exc.strerror or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise DeviceConfigError(f"{path}: not valid TOML: {exc}") from None
    unknown = set(data) - {"device"}
    if unknown:
        raise DeviceConfigError(f"{path}: unknown top-level key(s) {sorted(unknown)}; expected [[device]] tables")
    tables = data.get("device", [])
    if not isinstance(tables, list) or not tables:
        raise DeviceConfigError(f"{path}: no [[device]] tables")
    configs = [DeviceConfig.from_dict(t, f"{path} device #{i + 1}") for i, t in enumerate(tables)]
    try:
        check_unique(configs)
        check_browser_configs(configs)
    except (DeviceConfigError, BrowserConfigError) as exc:
        raise DeviceConfigError(f"{path}: {exc}") from None
    return configs


def with_fingers(configs: list[DeviceConfig], fingers: Mapping[str, str]) -> list[DeviceConfig]:
    """`configs` with the fingers of `fingers` (device name → point, `serve --finger NAME=POINT`)
    put in place; DeviceConfigError for a name no device has."""
    unknown = sorted(set(fingers) - {c.name for c in configs})
    if unknown:
        raise DeviceConfigError(f"--finger names no configured device: {', '.join(unknown)}; devices: "
                                f"{', '.join(c.name for c in configs) or 'none'}")
    return [replace(c, finger=fingers[c.name]) if c.name in fingers else c for c in configs]


def rig_points(fingers) -> tuple[str, ...]:
    """The tracked points devices sit on (`fingers`: each device's) besides the primary one, in
    order, each once: the loop makes a tool for each (server/loop/simulation.py)."""
    points: list[str] = []
    for finger in fingers:
        if finger != PRIMARY_POINT and finger not in points:
            points.append(finger)
    return tuple(points)


def check_unique(configs: list[DeviceConfig]) -> None:
    names = [c.name for c in configs]
    duplicate = {n for n in names if names.count(n) > 1}
    if duplicate:
        raise DeviceConfigError(f"device names must be unique; repeated: {', '.join(sorted(duplicate))} "
                                "(give each one a name: NAME=MODEL@PORT)")


def make_protocol(profile: DeviceProfile, link_share: float, baud: int, watchdog_ms: int = WATCHDOG_MS):
    byte_time_s = BYTE_TIME_S * 115_200 / baud  # 8N1 at this baud rate
    if profile.protocol == "line":
        return LineProtocol(dict(profile.line), share=link_share, byte_time_s=byte_time_s)
    # keepalives at a quarter of the watchdog, never more often than every 5 ms
    return DeviceSession(share=link_share, byte_time_s=byte_time_s, watchdog_ms=watchdog_ms,
                        keepalive_interval_s=max(0.005, watchdog_ms / 4000))


class _Managed:
    def __init__(self, config: DeviceConfig, driver):
        self.config = config
        self.profile = config.profile
        self.encoder = (AudioCueEncoder(config.profile, config.name, config.audio) if config.audio is not None
                        else CueEncoder(config.profile, config.name))
        self.driver = driver
        self.refusals: tuple[Refusal, ...] = ()


class DeviceManager:
    def __init__(self, configs: list[DeviceConfig], *, serial_factory=serial.Serial,
                 clock: Callable[[], float] = time.monotonic, reopen_interval_s: float = 0.5):
        check_unique(configs)
        self._lock = threading.Lock()
        self.listeners: list[Callable[[], None]] = []
        self.cues: tuple[Cue, ...] = ()  # the primary tool's
        self.finger_cues: Mapping[str, tuple[Cue, ...]] = {}  # the other tools', by point name
        self.refusals: tuple[Refusal, ...] = ()
        self.devices: dict[str, _Managed] = {}
        self._rejected: dict[str, tuple[int, float]] = {}  # name → (not yet logged, last log time)
        for config in configs:
            if config.audio is not None:  # a sound interface's channels: no serial port, no protocol
                self.devices[config.name] = _Managed(config, AudioDevice(
                    config.name, config.audio, config.profile.carrier_hz, reopen_interval_s=reopen_interval_s,
                    on_event=self._on_event))
                continue
            driver = SerialDevice(config.name, config.port, make_protocol(config.profile, config.link_share, config.baud,
                                                                                config.watchdog_ms),
                                  baud=config.baud, reopen_interval_s=reopen_interval_s, on_event=self._on_event,
                                  clock=clock, serial_factory=serial_factory)
            self.devices[config.name] = _Managed(config, driver)

    def start(self) -> None:
        for d in self.devices.values():
            d.driver.start()
            d.driver.set_commands(d.encoder.encode(()).commands.values())  # everything off until a cue says otherwise

    def stop(self) -> None:
        for d in self.devices.values():
            d.driver.stop()

    def submit(self, cues: tuple[Cue, ...], *, write_now: bool = False,
               finger_cues: Mapping[str, tuple[Cue, ...]] | None = None) -> tuple[Refusal, ...]:
        """A new cue set from the loop: encode for every device, hand over, return the refusals.
        `cues` are the primary tool's, `finger_cues` the other tools' by point name; a device gets
        its own finger's (none when its finger has none: off). `write_now`: the caller writes each
        device's first frame itself when that cannot block (SerialDevice.set_commands; the device
        feed does, saving a thread wake-up)."""
        with self._lock:
            self.cues = tuple(cues)
            self.finger_cues = dict(finger_cues or {})
            for d in self.devices.values():
                encoding = d.encoder.encode(self._cues_for(d))
                d.driver.set_commands(encoding.commands.values(), write_now=write_now)
                d.refusals = encoding.refusals
            return self._update_refusals()

    def _cues_for(self, d: _Managed) -> tuple[Cue, ...]:
        finger = d.config.finger
        return self.cues if finger == PRIMARY_POINT else tuple(self.finger_cues.get(finger, ()))

    def _update_refusals(self) -> tuple[Refusal, ...]:
        refusals = tuple(r for d in self.devices.values() for r in d.refusals)
        if refusals != self.refusals:
            for r in set(refusals) - set(self.refusals):
                log.warning("refused: %s", r.reason)
            self.refusals = refusals
            self._notify()
        return refusals

    def _on_event(self, name: str, event) -> None:
        if isinstance(event, Identified):
            identity = event.identity
            d = self.devices[name]
            caps = cap_names(identity.caps)
            firmware = f"{identity.fw_major}.{identity.fw_minor}.{identity.fw_patch}"
            if identity.model != d.config.profile.model:
                log.warning("%s: configured as %s but the device says it is %s; using what it reports",
                            name, d.config.profile.model, identity.model)
            with self._lock:
                d.profile = d.config.profile.with_identity(channels=identity.channels, caps=caps,
                                                           carrier_hz=identity.carrier_hz, firmware=firmware)
                d.encoder = CueEncoder(d.profile, name)
                encoding = d.encoder.encode(self._cues_for(d))
                d.driver.set_commands(encoding.commands.values())
                d.refusals = encoding.refusals
                self._update_refusals()
            log.info("%s: %s firmware %s, %d channel(s), caps %s", name, identity.model, firmware,
                     identity.channels, ",".join(sorted(caps)))
        if isinstance(event, FrameRejected):
            self._log_rejected(name, event)
        elif isinstance(event, DeviceErrorReported):
            log.warning("%s: the device answered ERROR %s to %s", name, event.code, event.message_repr)
        elif isinstance(event, CommandRefused):
            log.warning("%s: no line template for %s (%s)", name, event.message, event.reason)
        elif isinstance(event, WatchdogReported):
            log.warning("%s: the device's watchdog turned every actuator off (trip %d): the host was silent "
                        "too long; every layer is sent again", name, event.trips)
        elif isinstance(event, DeviceLine):
            log.debug("%s says: %s", name, event.text)
        if isinstance(event, UnderrunsCounted):
            self._notify()  # into the report: health shows it as a note
        if isinstance(event, StatusChanged):
            trouble = event.new in ("disconnected", "unresponsive", "bad_version", "refused") and event.reason != "stopped"
            level = logging.WARNING if trouble else logging.INFO
            log.log(level, "%s: %s -> %s (%s)", name, event.old, event.new, event.reason)
            self._notify()

    def _log_rejected(self, name: str, event) -> None:
        """Garbage on a line comes in bursts: log the first, then at most one summary a second."""
        now = time.monotonic()
        count, last = self._rejected.get(name, (0, 0.0))
        count += 1
        if now - last >= 1.0:
            log.warning("%s: rejected %d frame(s) from the device, latest %s; resynchronised at the next delimiter",
                        name, count, getattr(event.error, "kind", event.error))
            count, last = 0, now
        self._rejected[name] = (count, last)

    def _notify(self) -> None:
        for listener in self.listeners:
            listener()

    def report(self) -> dict:
        """What the hub and the loop need to know: refusals no device shows, and every status."""
        report = {"refusals": unshown_refusals(self.refusals, len(self.devices)), "status": self.status()}
        underruns = {name: d.driver.underruns for name, d in self.devices.items() if d.config.audio is not None}
        if underruns:  # audio devices: the blocks their audio server called for too late
            report["underruns"] = underruns
        return report

    def status(self) -> dict[str, str]:
        return {name: d.driver.status for name, d in self.devices.items()}

    def snapshot(self, writes: int = 0) -> dict:
        return {"devices": [{**d.driver.snapshot(writes), "profile": d.profile.to_dict(), "finger": d.config.finger,
                             "refusals": [r.to_dict() for r in d.refusals]} for d in self.devices.values()],
                "refusals": [r.to_dict() for r in self.refusals]}


def unshown_refusals(refusals, device_count: int) -> list[str]:
    """The reasons for cues that NO device shows: what the participant would otherwise miss
    without a word. A cue one device refuses and another shows (a FingerTac beside a FerroVibe
    in the contact-angle task) stays in /api/devices but does not clutter the participant's HUD."""
    by_cue: dict[str, list] = {}
    for r in refusals:
        by_cue.setdefault(r.cue, []).append(r)
    return [r.reason for cue, rs in by_cue.items() if len({r.device for r in rs}) >= device_count for r in rs]
