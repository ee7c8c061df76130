"""Serial port discovery: how a device config names its port, and what that port is right now.

A configured device names its port either by path (`/dev/ttyUSB0`, `/dev/rfcomm0`, a pty
symlink, `COM3`) or by USB identity (`usb:303a:1001[:SERIAL]`), because ttyUSBn/ttyACMn
numbers change with plug order; the identity is resolved to a path each time the host (re)opens
the port (docs/devices.md "Faults").

The other half is latency: FTDI-style USB-serial bridges hold received bytes for up to their
latency timer (16 ms by default, 1-255 ms) before sending them to the host, which delays every
device reply by that much (FTDI application note AN232B-04;
docs/devices.md "USB-serial latency timer"). Linux exposes the timer in sysfs; we read it and
say how to lower it. CP210x, CDC-ACM (ESP32 native USB), Bluetooth and ptys have no such timer.
"""

from __future__ import annotations

import logging
import os
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from serial.tools import list_ports as _list_ports
from serial.tools.list_ports_common import ListPortInfo

log = logging.getLogger(__name__)

SYSFS_ROOT = "/sys"
# Above this the timer, not the 115200-baud wire (~1 ms per 10-byte frame), dominates a reply's delay.
LATENCY_WARN_ABOVE_MS = 2

ACCEPTED_FORMS = ("an absolute path (/dev/ttyUSB0, /dev/rfcomm0, /dev/serial/by-id/...), "
                  "a Windows port (COM3), usb:VID:PID or usb:VID:PID:SERIAL with hex VID/PID "
                  "(e.g. usb:303a:1001:ABC123)")
_COM = re.compile(r"(?:\\\\\.\\)?COM[0-9]+", re.IGNORECASE)  # COM3 or \\.\COM10
_HEX16 = re.compile(r"(?:0x)?[0-9a-fA-F]{1,4}")


def _hex16(text: str, what: str, whole: str) -> int:
    if not _HEX16.fullmatch(text):
        raise ValueError(f"bad {what} {text!r} in port {whole!r}: expected 1-4 hex digits (e.g. 303a); "
                         f"accepted forms: {ACCEPTED_FORMS}")
    return int(text, 16)


@dataclass(frozen=True)
class PortSpec:
    """A device's port: exactly one of `path` or a USB identity (`vid`, `pid`, optional `serial`)."""
    path: str | None = None
    vid: int | None = None
    pid: int | None = None
    serial: str | None = None

    def __post_init__(self) -> None:
        usb = self.vid is not None or self.pid is not None or self.serial is not None
        if (self.path is None) == (not usb):
            raise ValueError("a PortSpec needs either a path or a USB vid/pid, not both or neither")
        if self.path is not None and (not isinstance(self.path, str) or not self.path.strip()):
            raise ValueError(f"PortSpec.path must be a non-empty string, got {self.path!r}")
        if usb:
            for name in ("vid", "pid"):
                value = getattr(self, name)
                if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value <= 0xFFFF:
                    raise ValueError(f"PortSpec.{name} must be an int in [0, 0xffff], got {value!r}")
            if self.serial is not None and not self.serial:
                raise ValueError("PortSpec.serial must be non-empty (or None for any serial number)")

    def __str__(self) -> str:
        """Canonical text; `PortSpec.parse(str(spec)) == spec`."""
        if self.path is not None:
            return self.path
        text = f"usb:{self.vid:04x}:{self.pid:04x}"
        return text if self.serial is None else f"{text}:{self.serial}"

    @classmethod
    def parse(cls, text: str) -> PortSpec:
        if not isinstance(text, str):
            raise ValueError(f"port must be a string, got {type(text).__name__}; accepted forms: {ACCEPTED_FORMS}")
        whole = text.strip()
        if not whole:
            raise ValueError(f"empty port; accepted forms: {ACCEPTED_FORMS}")
        if whole[:4].lower() == "usb:":
            parts = whole[4:].split(":", 2)  # the serial number may itself contain ':'
            if len(parts) < 2:
                raise ValueError(f"bad port {whole!r}: usb: needs VID:PID; accepted forms: {ACCEPTED_FORMS}")
            serial = parts[2] if len(parts) == 3 else None
            if serial is not None and not serial.strip():
                raise ValueError(f"bad port {whole!r}: empty serial number after VID:PID; "
                                 f"accepted forms: {ACCEPTED_FORMS}")
            return cls(vid=_hex16(parts[0], "VID", whole), pid=_hex16(parts[1], "PID", whole), serial=serial)
        if whole.startswith("/") or _COM.fullmatch(whole):
            return cls(path=whole)
        # Relative paths are refused: the server's working directory is not the config's directory.
        raise ValueError(f"bad port {whole!r}; accepted forms: {ACCEPTED_FORMS}")

    @classmethod
    def from_dict(cls, config: Mapping[str, Any]) -> PortSpec:
        """From a TOML device table: `port = "..."` (any `parse` form) or `[usb] vid/pid/serial`.

        Keys other than `port` and `usb` are ignored, so a whole device table can be passed.
        """
        if not isinstance(config, Mapping):
            raise ValueError(f"device port config must be a table, got {type(config).__name__}")
        has_port, has_usb = "port" in config, "usb" in config
        if has_port == has_usb:
            raise ValueError('device config needs exactly one of port = "/dev/ttyUSB0" (or "usb:303a:1001") '
                             'or usb = { vid = "303a", pid = "1001", serial = "..." }')
        if has_port:
            return cls.parse(config["port"])
        usb = config["usb"]
        if not isinstance(usb, Mapping):
            raise ValueError(f'usb must be a table like {{ vid = "303a", pid = "1001" }}, got {usb!r}')
        unknown = set(usb) - {"vid", "pid", "serial"}
        if unknown or "vid" not in usb or "pid" not in usb:
            raise ValueError(f"usb table needs vid and pid (hex strings) and may have serial; got keys {sorted(usb)}")
        ids = []
        for name in ("vid", "pid"):
            value = usb[name]
            # TOML `pid = 1001` is decimal 1001 = 0x3e9, almost surely not meant: insist on hex strings.
            if not isinstance(value, str):
                raise ValueError(f'usb.{name} must be a hex string like "303a", got {value!r}')
            ids.append(_hex16(value.strip(), name.upper(), f"usb.{name}"))
        serial = usb.get("serial")
        if serial is not None and (not isinstance(serial, str) or not serial):
            raise ValueError(f"usb.serial must be a non-empty string, got {serial!r}")
        return cls(vid=ids[0], pid=ids[1], serial=serial)


@dataclass(frozen=True)
class PortMatch:
    """Outcome of resolving a spec: the chosen device (or None), every candidate, and a warning to log."""
    device: str | None
    candidates: tuple[str, ...] = ()
    warning: str | None = None


def _natural_key(device: str) -> list[Any]:
    # ttyACM2 before ttyACM10: deterministic and what a person expects.
    return [(0, int(part), "") if part.isdigit() else (1, 0, part) for part in re.split(r"(\d+)", device)]


def _comports(ports: Iterable[ListPortInfo] | None) -> list[ListPortInfo]:
    return list(_list_ports.comports() if ports is None else ports)


def find_port(spec: PortSpec, ports: Iterable[ListPortInfo] | None = None) -> PortMatch:
    """Resolve `spec` to a device path now; `ports` replaces `comports()` (tests)."""
    if spec.path is not None:
        if os.path.exists(spec.path):  # follows symlinks: a dangling by-id link means unplugged
            return PortMatch(spec.path, (spec.path,))
        if _COM.fullmatch(spec.path):  # Windows COM names are not filesystem paths: ask the OS list
            wanted = spec.path.upper().removeprefix("\\\\.\\")
            for port in _comports(ports):
                if port.device.upper().removeprefix("\\\\.\\") == wanted:
                    return PortMatch(port.device, (port.device,))
        return PortMatch(None)
    found = sorted((p.device for p in _comports(ports)
                    if p.vid == spec.vid and p.pid == spec.pid
                    and (spec.serial is None or p.serial_number == spec.serial)), key=_natural_key)
    if not found:
        return PortMatch(None)
    warning = None
    if len(found) > 1:
        warning = (f"port {spec} matches {len(found)} devices ({', '.join(found)}); using {found[0]}. "
                   f"Add the serial number (usb:{spec.vid:04x}:{spec.pid:04x}:SERIAL; see `viestac devices`) "
                   f"to pick one")
    return PortMatch(found[0], tuple(found), warning)


def resolve(spec: PortSpec, ports: Iterable[ListPortInfo] | None = None,
            on_warning: Callable[[str], None] | None = None) -> str | None:
    """The device path for `spec` now, or None when absent. Ambiguity goes to `on_warning` (default: log)."""
    match = find_port(spec, ports)
    if match.warning is not None:
        (on_warning or log.warning)(match.warning)
    return match.device


def _tty_name(device_path: str) -> str:
    # /dev/serial/by-id/usb-FTDI_...-if00-port0 -> ../../ttyUSB0; sysfs knows only the kernel name.
    return os.path.basename(os.path.realpath(device_path))


def latency_timer_ms(device_path: str, sysfs_root: str = SYSFS_ROOT) -> int | None:
    """The USB-serial latency timer of `device_path` in ms, or None when it has none (pty, CDC-ACM, BT, non-Linux)."""
    path = os.path.join(sysfs_root, "bus", "usb-serial", "devices", _tty_name(device_path), "latency_timer")
    try:
        with open(path, encoding="ascii") as f:
            return int(f.read().strip())
    except (OSError, ValueError):
        return None


def _warning_for(device_path: str, timer_ms: int | None) -> str | None:
    if timer_ms is None or timer_ms <= LATENCY_WARN_ABOVE_MS:
        return None
    tty = _tty_name(device_path)
    dev = f"/dev/{tty}"
    shown = device_path if device_path == dev else f"{device_path} ({dev})"
    return (f"{shown}: USB-serial latency timer is {timer_ms} ms, which adds up to {timer_ms} ms of delay to every "
            f"device reply; set it to 1 ms: `echo 1 | sudo tee /sys/bus/usb-serial/devices/{tty}/latency_timer` "
            f"(until unplugged), or persistently with a udev rule "
            f'`ACTION=="add", SUBSYSTEM=="usb-serial", DRIVER=="ftdi_sio", ATTR{{latency_timer}}="1"`, '
            f"or `setserial {dev} low_latency`")


def latency_warning(device_path: str, sysfs_root: str = SYSFS_ROOT) -> str | None:
    """One line to log when the latency timer is above LATENCY_WARN_ABOVE_MS, else None."""
    return _warning_for(device_path, latency_timer_ms(device_path, sysfs_root))


def list_ports(sysfs_root: str = SYSFS_ROOT, ports: Iterable[ListPortInfo] | None = None) -> list[dict[str, Any]]:
    """Every serial port the OS reports, sorted by device, for `viestac devices`.

    vid/pid are 4-digit lowercase hex strings (as written in a port spec) or None; `spec` is the
    text to put in a device config (usb:VID:PID:SERIAL when the port is USB, else the path).
    """
    rows = []
    for p in sorted(_comports(ports), key=lambda p: _natural_key(p.device)):
        timer = latency_timer_ms(p.device, sysfs_root)
        usb = p.vid is not None and p.pid is not None
        spec = (PortSpec(vid=p.vid, pid=p.pid, serial=p.serial_number or None) if usb else PortSpec(path=p.device))
        rows.append({
            "device": p.device, "description": p.description, "hwid": p.hwid,
            "vid": f"{p.vid:04x}" if usb else None, "pid": f"{p.pid:04x}" if usb else None,
            "serial_number": p.serial_number, "manufacturer": p.manufacturer,
            "latency_timer_ms": timer, "warning": _warning_for(p.device, timer), "spec": str(spec),
        })
    return rows
