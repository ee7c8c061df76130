"""The firmware watchdog end to end on simulated time: DeviceSession (with the production
defaults of devices.manager.make_protocol) against the real C firmware core (devices.firmware_binding).
The host arms it at the handshake and keeps it fed; a host that goes silent leaves every actuator
off within the watchdog's timeout, and when it speaks again it learns so and shows every layer
again. A firmware that predates the watchdog (tests/devices/fake_device.py) keeps working as before."""

from __future__ import annotations

from devices import messages as m
from devices.simulated_link import SimulatedLink
from tests.devices.fake_device import FERROVIBE, FakeDevice
from devices.framing import FrameDecoder, FrameError
from devices.firmware_binding import Firmware
from devices.manager import make_protocol
from devices.profiles import profile_by_model
from devices.protocol import DeviceSession, WatchdogReported

TICK_S = 0.0005


class FirmwareLink:
    """Host and C firmware joined by an instant wire; `host_alive` False = the host process is gone."""

    def __init__(self, host: DeviceSession, model: str = "ferrovibe"):
        self.host, self.core = host, Firmware(model)
        self.t = 0.0
        self.host_alive = True
        self.writes: list[tuple[float, bytes]] = []
        self.edges = []
        self.events = []
        self.host.connection_made(0.0)

    def run_until(self, t_end: float) -> None:
        while self.t < t_end:
            self.t = round(self.t + TICK_S, 6)
            now_us = int(self.t * 1e6)
            if self.host_alive:
                data, _ = self.host.poll(self.t)
                if data:
                    self.writes.append((self.t, data))
                    self.core.receive(data, now_us)
            self.edges += self.core.advance(now_us)
            reply = self.core.take_output()
            if self.host_alive and reply:
                self.host.receive_data(reply, self.t)
            if self.host_alive:
                self.events += self.host.events_received()


def ferrovibe_host() -> DeviceSession:
    return make_protocol(profile_by_model("ferrovibe"), 0.5, 115200)


def test_the_host_arms_the_watchdog_and_keeps_it_fed_while_nothing_changes():
    sim = FirmwareLink(ferrovibe_host())
    sim.host.set(m.SetTilt(0, 31500, 100), 0.0)
    sim.run_until(3.0)
    assert sim.host.status == "connected" and sim.host.watchdog == "on"
    assert sim.core.watchdog_deadline_us() is not None
    assert [e.cause for e in sim.edges] == ["command"], "a held tilt stays: the watchdog never tripped"
    gaps = [b[0] - a[0] for a, b in zip(sim.writes, sim.writes[1:]) if a[0] > 0.1]
    assert max(gaps) <= sim.host.keepalive_interval_s + TICK_S
    sent = sum(len(d) for t, d in sim.writes if t > 1.0) / 2.0  # bytes per second while idle
    assert sent < 0.10 * 11_520, "keepalives stay a small part of the link (7.7 % at the defaults)"


def test_a_silent_host_leaves_every_actuator_off_within_the_watchdog_and_gets_them_back():
    sim = FirmwareLink(ferrovibe_host())
    sim.host.set(m.SetTilt(0, 31500, 100), 0.0)
    sim.run_until(1.0)
    assert sim.edges[-1].magnitude == 100
    sim.host_alive = False  # the device host died, hangs, or the link lost it
    last_frame = sim.writes[-1][0]
    sim.run_until(1.5)
    trip = [e for e in sim.edges if e.cause == "watchdog"]
    assert len(trip) == 1 and trip[0].magnitude == 0
    assert trip[0].t_us == round((last_frame + sim.host.watchdog_ms / 1000) * 1e6), "at the exact expiry"
    assert sim.core.counters()["watchdog_trips"] == 1

    sim.host_alive = True  # it was only stalled: it speaks again and learns what happened
    sim.run_until(1.6)
    assert any(isinstance(e, WatchdogReported) for e in sim.events) and sim.host.counters["watchdog_trips"] == 1
    assert sim.edges[-1].magnitude == 100 and sim.edges[-1].direction_cdeg == 31500, "every layer shown again"


def test_a_firmware_without_the_watchdog_keeps_working_without_keepalives():
    sim = SimulatedLink(ferrovibe_host(), FakeDevice(FERROVIBE))
    sim.plug()
    sim.set(m.SetTilt(0, 9000, 100))
    sim.run_until(2.0)
    assert sim.host.status == "connected" and sim.host.watchdog == "unsupported"
    assert sim.device.layer(0, "tilt") == m.SetTilt(0, 9000, 100)
    pings = [t for t, msg in sim.written_messages() if isinstance(msg, m.Ping) and t > 0.1]
    assert len(pings) <= 4, "back to the 0.5 s heartbeat: no keepalives for a device that cannot use them"


def test_old_hosts_are_unchanged_the_watchdog_is_off_until_a_host_arms_it():
    core = Firmware("ferrovibe")
    assert core.watchdog_deadline_us() is None
    host = DeviceSession()  # no watchdog_ms: what a host before SET_WATCHDOG sends
    sim = FirmwareLink(host)
    sim.host.set(m.SetTilt(0, 9000, 100), 0.0)
    sim.run_until(2.0)
    assert host.watchdog == "off" and sim.core.watchdog_deadline_us() is None
    decoder = FrameDecoder()
    types = {f.type for _, data in sim.writes for f in decoder.feed(data) if not isinstance(f, FrameError)}
    assert m.Ping.TYPE in types and m.SetWatchdog.TYPE not in types
    assert [e.cause for e in sim.edges] == ["command"]
