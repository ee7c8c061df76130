"""A virtual device runs lazily (it catches up when read or handed a command): driven the same
way, it plays the same edges and sends the same bytes as one brought up to date every tick."""

import math

from devices.profiles import profile_by_model
from server.core.cues import PulseTrain, Tilt
from server.simulate.virtual_device import VirtualDevice


def drive(model: str, every_tick: bool) -> tuple[list, list]:
    """Three seconds of a cue that changes every 7th tick, as a moving finger makes it."""
    device = VirtualDevice(model, profile_by_model(model))
    for tick in range(3000):
        if tick % 7 == 0 and tick > 50:  # after the handshake has begun
            k = tick // 7
            device.submit((PulseTrain(t_on_ms=20 + k % 30, t_off_ms=40 + k % 90, intensity_pct=30 + k % 70),
                           Tilt(direction_deg=(k * 11) % 360, magnitude_pct=10 + k % 90)))
        device.run_until((tick + 1) / 1000)
        if every_tick:
            device.catch_up()
    return device.edges, device.link.writes


def test_lazy_and_tick_by_tick_devices_play_the_same_edges_and_send_the_same_bytes():
    for model in ("fingertac", "ferrovibe"):
        lazy_edges, lazy_writes = drive(model, every_tick=False)
        eager_edges, eager_writes = drive(model, every_tick=True)
        assert len(eager_edges) > 100 and len(eager_writes) > 100, "the device played and the host wrote"
        assert lazy_edges == eager_edges and lazy_writes == eager_writes, model


def test_reading_the_feel_brings_the_device_up_to_now():
    device = VirtualDevice("ferrovibe", profile_by_model("ferrovibe"))
    for tick in range(200):  # connect
        device.run_until((tick + 1) / 1000)
    assert device.status == "connected"
    device.submit((Tilt(direction_deg=90.0, magnitude_pct=80),))
    for tick in range(200, 400):
        device.run_until((tick + 1) / 1000)
    direction, magnitude = device.feel.tilt()  # nothing ran since the submit until this read
    assert magnitude == 80 and math.isclose(direction, 90.0)
    assert device.edges[-1].t_us <= 400_000
