"""The device host process for real: a FerroVibe emulator on a pty, cue records sent on the loop end
of the cue channel as the loop process sends them, reports and snapshots over the control
channel, a restart after the process dies, and everything off when it stops."""

from __future__ import annotations

import asyncio
import os
import signal
import time

import msgpack
import pytest

from devices.emulator import Emulator
from devices.manager import DeviceConfig
from devices.ports import PortSpec
from devices.profiles import profile_by_model
from server.hub.device_host import DeviceHost
from server import ipc
from server.ipc.records import Cues

TILT = {"kind": "tilt", "direction_deg": 90.0, "magnitude_pct": 100.0}


async def until(predicate, timeout_s: float, message: str):
    deadline = time.monotonic() + timeout_s
    while not (value := predicate()):
        if time.monotonic() > deadline:
            raise AssertionError(message)
        await asyncio.sleep(0.01)
    return value


@pytest.fixture
def emulator(tmp_path):
    emulator = Emulator("ferrovibe", link=tmp_path / "ferrovibe")
    emulator.start()
    yield emulator
    emulator.stop()


def shows(emulator, magnitude: int, direction_cdeg: int | None = None):
    edges = [e for e in emulator.snapshot_edges() if e.cause == "command"]
    return edges and edges[-1].magnitude == magnitude and direction_cdeg in (None, edges[-1].direction_cdeg)


def test_cues_from_the_loop_end_reach_the_device_and_stopping_turns_it_off(emulator):
    async def go():
        reports, profiles = [], []
        config = DeviceConfig("ferro", profile_by_model("ferrovibe"), PortSpec.parse(emulator.path))
        # no loop sends heartbeats here: a quiet time far beyond the test keeps the cues on
        host = DeviceHost([config], on_report=reports.append, on_profiles=profiles.append, cue_quiet_ms=600_000)
        host.start()
        try:
            await until(lambda: reports and reports[-1]["status"] == {"ferro": "connected"}, 5.0, "never connected")
            assert profiles and profiles[-1]["ferro"].model == "ferrovibe"
            assert ipc.send_record(host.loop_end, Cues(1, time.monotonic_ns(), [TILT]))  # as the loop does
            await until(lambda: shows(emulator, 100, 9000), 3.0, "the tilt never reached the device")
            assert host._sock.send(msgpack.packb(["bogus"])) and host._sock.send(msgpack.packb(["submit", [{"kind": "nonsense"}]]))  # logged, survived
            snapshot = await host.snapshot(writes=8)
            device = snapshot["devices"][0]
            assert device["name"] == "ferro" and device["status"] == "connected" and device["writes"]
            assert snapshot["feed"]["records"] == 1 and snapshot["feed"]["last_tick"] == 1
            assert shows(emulator, 100, 9000), "the bad requests changed nothing"
            assert host.info["pid"] == host.proc.pid

            os.kill(host.proc.pid, signal.SIGKILL)  # a crash: the hub starts it again, the channel stays
            await until(lambda: host.restarts == 1 and host.alive and host.info["pid"] == host.proc.pid, 10.0,
                        "the device host was not restarted")
            await until(lambda: reports[-1]["status"] == {"ferro": "connected"}, 5.0, "no reconnect after restart")
            assert ipc.send_record(host.loop_end, Cues(2, time.monotonic_ns(), [{**TILT, "direction_deg": 180.0}]))
            await until(lambda: shows(emulator, 100, 18000), 3.0, "cues did not flow after the restart")
        finally:
            await host.stop()
        assert shows(emulator, 0), "stopping leaves every actuator off"
        assert not host.alive

    asyncio.run(go())


def test_a_snapshot_of_a_host_that_is_gone_says_so():
    async def go():
        host = DeviceHost([], on_report=lambda report: None)
        with pytest.raises(RuntimeError, match="not running"):
            await host.snapshot()
        host.device_end.close()
        host.loop_end.close()

    asyncio.run(go())


def test_a_snapshot_asked_of_a_host_that_died_fails_at_once_not_after_the_timeout():
    from server.hub.device_host import DeviceHostUnavailable

    async def go():
        host = DeviceHost([], on_report=lambda report: None)
        try:
            waiting = asyncio.get_running_loop().create_future()
            host._requests[1] = waiting  # asked; the process dies before it answers
            host._closed()
            with pytest.raises(DeviceHostUnavailable, match="exited"):
                await asyncio.wait_for(waiting, 0.1)
        finally:
            host.device_end.close()
            host.loop_end.close()

    asyncio.run(go())
