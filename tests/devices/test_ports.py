"""Port specs, resolution against fake port lists, and the sysfs latency timer (fake tree + a real pty)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from serial.tools.list_ports_common import ListPortInfo

from devices.ports import (LATENCY_WARN_ABOVE_MS, PortMatch, PortSpec, find_port, latency_timer_ms,
                           latency_warning, list_ports, resolve)


def port(device: str, vid: int | None = None, pid: int | None = None, serial: str | None = None,
         manufacturer: str | None = None) -> ListPortInfo:
    info = ListPortInfo(device, skip_link_detection=True)
    info.vid, info.pid, info.serial_number, info.manufacturer = vid, pid, serial, manufacturer
    if vid is not None:
        info.apply_usb_info()
    return info


def fake_sysfs(root: Path, timers: dict[str, str]) -> str:
    for tty, text in timers.items():
        d = root / "bus" / "usb-serial" / "devices" / tty
        d.mkdir(parents=True)
        (d / "latency_timer").write_text(text)
    return str(root)


# --- parsing -------------------------------------------------------------------------------------

@pytest.mark.parametrize("text, expected", [
    ("/dev/ttyUSB0", PortSpec(path="/dev/ttyUSB0")),
    ("/dev/rfcomm0", PortSpec(path="/dev/rfcomm0")),
    ("  /tmp/vt-fingertac\n", PortSpec(path="/tmp/vt-fingertac")),
    ("COM3", PortSpec(path="COM3")),
    (r"\\.\COM10", PortSpec(path=r"\\.\COM10")),
    ("usb:303a:1001", PortSpec(vid=0x303A, pid=0x1001)),
    ("USB:303A:0x1001", PortSpec(vid=0x303A, pid=0x1001)),
    ("usb:303a:1001:ABC123", PortSpec(vid=0x303A, pid=0x1001, serial="ABC123")),
    ("usb:403:6001:A1:B2", PortSpec(vid=0x0403, pid=0x6001, serial="A1:B2")),  # serial may hold ':'
])
def test_parse_accepted_forms(text, expected):
    spec = PortSpec.parse(text)
    assert spec == expected
    assert PortSpec.parse(str(spec)) == spec


@pytest.mark.parametrize("text, fragment", [
    ("", "empty port"),
    ("   ", "empty port"),
    ("ttyUSB0", "bad port"),  # relative path
    ("usb:", "needs VID:PID"),
    ("usb:303a", "needs VID:PID"),
    ("usb:xyz:1001", "bad VID"),
    ("usb:303a:10010", "bad PID"),
    ("usb:303a:", "bad PID"),
    ("usb:303a:1001:", "empty serial"),
    ("loop://", "bad port"),
    ("303a:1001", "bad port"),
])
def test_parse_rejects_malformed_text_and_lists_accepted_forms(text, fragment):
    with pytest.raises(ValueError) as err:
        PortSpec.parse(text)
    assert fragment in str(err.value)
    assert "usb:VID:PID" in str(err.value)


def test_from_dict():
    assert PortSpec.from_dict({"port": "/dev/ttyUSB0", "name": "fingertac"}) == PortSpec(path="/dev/ttyUSB0")
    assert PortSpec.from_dict({"port": "usb:303a:1001"}) == PortSpec(vid=0x303A, pid=0x1001)
    assert PortSpec.from_dict({"usb": {"vid": "303a", "pid": "1001", "serial": "S1"}}) == \
        PortSpec(vid=0x303A, pid=0x1001, serial="S1")
    assert PortSpec.from_dict({"usb": {"vid": "0403", "pid": "6001"}}).serial is None


@pytest.mark.parametrize("config", [
    {}, {"name": "x"}, {"port": "/dev/ttyUSB0", "usb": {"vid": "1", "pid": "2"}},
    {"port": 3}, {"usb": "303a:1001"}, {"usb": {"vid": "303a"}},
    {"usb": {"vid": "303a", "pid": "1001", "serial_number": "x"}},
    {"usb": {"vid": 0x303A, "pid": 1001}},  # TOML ints are ambiguous (pid = 1001 is decimal)
    {"usb": {"vid": "303a", "pid": "1001", "serial": ""}},
    {"usb": {"vid": "g", "pid": "1001"}},
])
def test_from_dict_rejects_bad_tables(config):
    with pytest.raises(ValueError):
        PortSpec.from_dict(config)


@pytest.mark.parametrize("kwargs", [{}, {"path": "/dev/x", "vid": 1, "pid": 2}, {"vid": 1}, {"vid": 0x10000, "pid": 1},
                                    {"path": ""}, {"vid": 1, "pid": 2, "serial": ""}])
def test_constructor_invariants(kwargs):
    with pytest.raises(ValueError):
        PortSpec(**kwargs)


# --- resolution ----------------------------------------------------------------------------------

PORTS = [
    port("/dev/ttyUSB0", 0x0403, 0x6001, "FT1"),
    port("/dev/ttyACM10", 0x303A, 0x1001, "ESP-B"),
    port("/dev/ttyACM2", 0x303A, 0x1001, "ESP-A"),
    port("/dev/ttyS0"),
]


def test_resolve_by_vid_pid_and_serial():
    assert resolve(PortSpec.parse("usb:0403:6001"), PORTS) == "/dev/ttyUSB0"
    assert resolve(PortSpec.parse("usb:303a:1001:ESP-B"), PORTS) == "/dev/ttyACM10"
    assert resolve(PortSpec.parse("usb:303a:1001:ESP-A"), PORTS) == "/dev/ttyACM2"
    assert resolve(PortSpec.parse("usb:303a:1001:nope"), PORTS) is None
    assert resolve(PortSpec.parse("usb:303a:1002"), PORTS) is None
    assert resolve(PortSpec.parse("usb:303a:1001"), []) is None


def test_ambiguous_usb_spec_picks_first_device_and_reports_it():
    warnings: list[str] = []
    assert resolve(PortSpec.parse("usb:303a:1001"), PORTS, on_warning=warnings.append) == "/dev/ttyACM2"
    assert len(warnings) == 1 and "2 devices" in warnings[0] and "usb:303a:1001:SERIAL" in warnings[0]
    match = find_port(PortSpec.parse("usb:303a:1001"), reversed(PORTS))  # order of the OS list is irrelevant
    assert match.device == "/dev/ttyACM2" and match.candidates == ("/dev/ttyACM2", "/dev/ttyACM10")
    assert find_port(PortSpec.parse("usb:0403:6001"), PORTS) == PortMatch("/dev/ttyUSB0", ("/dev/ttyUSB0",))


def test_ambiguity_is_logged_by_default(caplog):
    with caplog.at_level("WARNING", logger="devices.ports"):
        resolve(PortSpec.parse("usb:303a:1001"), PORTS)
    assert "matches 2 devices" in caplog.text


def test_path_spec_resolves_to_itself_when_it_exists(tmp_path):
    target = tmp_path / "pty-target"
    target.touch()
    link = tmp_path / "vt-fingertac"
    link.symlink_to(target)
    assert resolve(PortSpec(path=str(link)), []) == str(link)  # the configured name, not the target
    target.unlink()
    assert resolve(PortSpec(path=str(link)), []) is None  # dangling link: device gone
    assert resolve(PortSpec(path=str(tmp_path / "absent")), []) is None


def test_com_port_resolves_through_the_os_list():
    assert resolve(PortSpec.parse("com3"), [port("COM3", 0x10C4, 0xEA60)]) == "COM3"
    assert resolve(PortSpec.parse("COM4"), [port("COM3")]) is None


# --- latency timer -------------------------------------------------------------------------------

def test_latency_timer_follows_symlinks(tmp_path):
    sysfs = fake_sysfs(tmp_path / "sys", {"ttyUSB0": "16\n", "ttyUSB1": "1\n"})
    dev = tmp_path / "dev"
    (dev / "serial" / "by-id").mkdir(parents=True)
    (dev / "ttyUSB0").touch()
    by_id = dev / "serial" / "by-id" / "usb-FTDI_FT232R_USB_UART_A1-if00-port0"
    by_id.symlink_to("../../ttyUSB0")
    assert latency_timer_ms(str(by_id), sysfs) == 16
    assert latency_timer_ms("/dev/ttyUSB1", sysfs) == 1
    assert latency_timer_ms("/dev/ttyACM0", sysfs) is None  # CDC-ACM: no file


def test_latency_timer_garbage_is_none(tmp_path):
    assert latency_timer_ms("/dev/ttyUSB0", fake_sysfs(tmp_path, {"ttyUSB0": "fast"})) is None


def test_latency_warning_threshold(tmp_path):
    sysfs = fake_sysfs(tmp_path, {"ttyUSB0": "16", "ttyUSB1": str(LATENCY_WARN_ABOVE_MS),
                                  "ttyUSB2": str(LATENCY_WARN_ABOVE_MS + 1)})
    warning = latency_warning("/dev/ttyUSB0", sysfs)
    assert warning is not None and "\n" not in warning
    assert "16 ms of delay to every device reply" in warning
    assert "echo 1 | sudo tee /sys/bus/usb-serial/devices/ttyUSB0/latency_timer" in warning
    assert 'ACTION=="add", SUBSYSTEM=="usb-serial", DRIVER=="ftdi_sio", ATTR{latency_timer}="1"' in warning
    assert "setserial /dev/ttyUSB0 low_latency" in warning
    assert latency_warning("/dev/ttyUSB1", sysfs) is None
    assert latency_warning("/dev/ttyUSB2", sysfs) is not None
    assert latency_warning("/dev/ttyACM0", sysfs) is None


def test_list_ports_rows_sorted_with_timers(tmp_path):
    sysfs = fake_sysfs(tmp_path, {"ttyUSB0": "16"})
    rows = list_ports(sysfs, ports=PORTS)
    assert [r["device"] for r in rows] == ["/dev/ttyACM2", "/dev/ttyACM10", "/dev/ttyS0", "/dev/ttyUSB0"]
    assert set(rows[0]) == {"device", "description", "hwid", "vid", "pid", "serial_number", "manufacturer",
                            "latency_timer_ms", "warning", "spec"}
    esp, serial0, ftdi = rows[0], rows[2], rows[3]
    assert (esp["vid"], esp["pid"], esp["serial_number"]) == ("303a", "1001", "ESP-A")
    assert esp["spec"] == "usb:303a:1001:ESP-A"
    assert esp["latency_timer_ms"] is None and esp["warning"] is None
    assert serial0["vid"] is None and serial0["spec"] == "/dev/ttyS0"
    assert ftdi["latency_timer_ms"] == 16 and "16 ms" in ftdi["warning"]
    assert "VID:PID=0403:6001" in ftdi["hwid"]


def test_list_ports_real_os_list_runs():
    rows = list_ports()  # whatever this machine has (maybe nothing): must not raise
    assert all(isinstance(r["device"], str) and "warning" in r for r in rows)


# --- a real pseudo-terminal ----------------------------------------------------------------------

def test_real_pty_resolves_by_path_and_has_no_latency_timer():
    master, slave = os.openpty()
    try:
        name = os.ttyname(slave)
        spec = PortSpec.parse(name)
        assert resolve(spec) == name
        assert latency_timer_ms(name) is None
        assert latency_warning(name) is None
    finally:
        os.close(slave)
        os.close(master)
