"""The simulated rig's emulators are separate processes: one killed with SIGKILL stays missing
(the rig does not hide a dead device), and once started again at the same link the host's
reader reopens it and the device is connected and identified again within 1 s."""

from __future__ import annotations

import csv
import os
import signal
import tempfile
import time

from devices.manager import DeviceManager
from devices.rig import SimulatedRig


def wait_for(predicate, timeout_s: float, message: str) -> float:
    start = time.monotonic()
    while not predicate():
        if time.monotonic() - start > timeout_s:
            raise AssertionError(message)
        time.sleep(0.005)
    return time.monotonic() - start


def test_a_killed_emulator_stays_missing_until_restarted_then_reconnects_within_1_s(tmp_path):
    rig = SimulatedRig(("ferrovibe",), directory=tmp_path)
    manager = DeviceManager(rig.start())
    manager.start()
    try:
        wait_for(lambda: manager.status()["ferrovibe"] == "connected", 5.0, "never connected")
        first = rig.procs["ferrovibe"]
        os.kill(first.pid, signal.SIGKILL)
        wait_for(lambda: manager.status()["ferrovibe"] == "disconnected", 1.0, "the dead device was not noticed")
        time.sleep(1.0)  # several reopen attempts on the dead link
        assert manager.status()["ferrovibe"] == "disconnected"
        assert rig.info()["emulators"]["ferrovibe"]["alive"] is False, "a dead emulator shows as dead"
        manager.devices["ferrovibe"].driver.protocol.identity = None  # must be identified afresh

        rig.restart("ferrovibe")
        up = time.monotonic()
        took = wait_for(lambda: manager.status()["ferrovibe"] == "connected"
                        and manager.devices["ferrovibe"].driver.protocol.identity is not None, 2.0, "no reconnect")
        print(f"\nreconnected {took * 1000:.0f} ms after the restarted emulator was up")
        assert took <= 1.0
        assert rig.procs["ferrovibe"].pid != first.pid and rig.info()["emulators"]["ferrovibe"]["alive"]
        snap = manager.snapshot()["devices"][0]
        assert snap["connects"] == 2 and snap["disconnects"] == 1
        assert up  # (the restart returned only once the link pointed at the new pty)
    finally:
        manager.stop()
        rig.stop()
    with open(rig.timeline("ferrovibe")) as f:
        rows = list(csv.reader(f))
    assert rows[0][0] == "t_us" and sum(r[0] == "t_us" for r in rows) == 1, "one timeline across the restart"


def test_a_link_that_now_leads_to_another_pty_is_followed(tmp_path):
    """A dead emulator's link dangles at its pty number, which the next pty anyone opens may get:
    the host then holds a stranger's port. When the device comes back (its link replaced), the
    host must leave the old node and follow the link, not stay on it for ever."""
    from devices.emulator import Emulator
    from devices.manager import DeviceConfig
    from devices.ports import PortSpec
    from devices.profiles import profile_by_model

    stranger = Emulator("fingertac", link=tmp_path / "stranger")
    stranger.start()
    link = tmp_path / "ferrovibe"
    os.symlink(stranger.pty_path, link)  # the stale link now reaches somebody else's pty
    manager = DeviceManager([DeviceConfig("ferrovibe", profile_by_model("ferrovibe"), PortSpec.parse(str(link)))])
    manager.start()
    device = None
    try:
        wait_for(lambda: manager.devices["ferrovibe"].driver.protocol.identity is not None, 3.0, "no handshake")
        assert manager.devices["ferrovibe"].driver.protocol.identity.model == "fingertac"
        device = Emulator("ferrovibe", link=link)  # the real device comes back: its link replaces the stale one
        device.start()
        took = wait_for(lambda: (identity := manager.devices["ferrovibe"].driver.protocol.identity) is not None
                        and identity.model == "ferrovibe" and manager.status()["ferrovibe"] == "connected", 2.0,
                        "the host stayed on the stranger's pty")
        print(f"\nfollowed the link in {took * 1000:.0f} ms")
        assert took <= 1.0
    finally:
        manager.stop()
        stranger.stop()
        if device is not None:
            device.stop()


def test_a_rig_removes_the_directory_it_made_and_keeps_one_it_was_given(tmp_path, monkeypatch):
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))  # where its own directory goes
    made = SimulatedRig(("fingertac",))
    made.start()
    own = made.directory
    assert own.parent == tmp_path and made.link("fingertac").exists()
    made.stop()
    assert not own.exists() and made.directory is None
    given = SimulatedRig(("fingertac",), directory=tmp_path / "kept")
    given.start()
    given.stop()
    assert given.timeline("fingertac").exists(), "a directory the caller chose keeps the timeline"
