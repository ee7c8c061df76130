"""docs/devices.md "Add your device": the serial-protocol and browser recipes' rig files, read as written
(only the emulator's link swapped for this test's), run on the simulated rig. The line-protocol
recipe runs in tests/devices/test_device_config.py, the audio one in tests/audio/test_recipe.py."""

from __future__ import annotations

import asyncio
import re
import time
from pathlib import Path

import msgpack
import websockets

from devices.emulator import Emulator
from devices.manager import DeviceManager, load_device_file
from server.core.cues import Friction, Temperature, Tilt
from server.core.points import PRIMARY_POINT
from tests.live_server import admin_token, get_json, start_server, stop_server

DOC = Path(__file__).resolve().parents[2] / "docs" / "devices.md"


def recipe(first_line: str) -> str:
    text = DOC.read_text(encoding="utf-8")
    return next(b for b in re.findall(r"```toml\n(.*?)```", text, re.S) if b.startswith(first_line))


def wait_for(predicate, timeout: float, what: str):
    deadline = time.monotonic() + timeout
    while not (got := predicate()):
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.02)
    return got


def test_the_serial_protocol_recipe_runs_on_the_devkit_emulator(tmp_path):
    text = recipe("# pintac-rig.toml")
    assert 'port = "/tmp/viestac-lab/pintac"' in text
    rig = tmp_path / "pintac-rig.toml"
    rig.write_text(text.replace("/tmp/viestac-lab/pintac", str(tmp_path / "pintac")))
    (config,) = load_device_file(rig)
    assert config.profile.protocol == "binary" and config.profile.table_row() == {
        "stiffness": "(!)", "macro_roughness": "(!)", "fine_roughness": "!", "temperature": "!", "friction": "-"}
    emulator = Emulator("devkit", link=tmp_path / "pintac")
    emulator.start()
    manager = DeviceManager([config], reopen_interval_s=0.1)
    manager.start()
    try:
        wait_for(lambda: manager.status()["pintac"] == "connected", 5, "the device to connect")
        assert manager.submit((Tilt(direction_deg=90.0, magnitude_pct=70.0), Temperature(celsius=34.0))) == ()
        wait_for(lambda: any(e.mode == 2 and e.intensity == 70 and e.magnitude == 0 and e.temperature_c == 34.0
                             for e in emulator.snapshot_edges()), 2, "the tilt as vibration at 70 % and 34 °C")
        (refusal,) = manager.submit((Friction(coefficient=0.5),))
        assert refusal.code == "not_displayed" and refusal.reason.startswith("pintac (devkit) cannot show the friction")
    finally:
        manager.stop()
        emulator.stop()


def test_the_browser_recipe_is_connected_by_a_page_that_offers_an_actuator_and_drives_it(tmp_path):
    rig = tmp_path / "browser-rig.toml"
    rig.write_text(recipe("# browser-rig.toml"))
    (config,) = load_device_file(rig)
    assert (config.name, config.profile.model, config.port, config.finger) == ("controller", "browser", None,
                                                                               PRIMARY_POINT)
    proc, base = start_server("free-v1", ["--devices", str(rig)])
    try:
        def device() -> dict:
            return next(d for d in get_json(base + "/api/devices")["devices"] if d["name"] == "controller")

        assert device()["status"] == "disconnected" and device()["port"] == "browser:/ws"

        async def page() -> list:
            url = base.replace("http://", "ws://") + "/ws"
            async with websockets.connect(url, subprotocols=["viestac.v1.msgpack"]) as ws:
                await ws.send(msgpack.packb({"type": "hello", "v": 1, "role": "participant", "client": "recipe",
                                             "token": admin_token(url)}))
                await ws.send(msgpack.packb({"type": "actuators", "actuators": [["gamepad", "none"]]}))
                await asyncio.to_thread(wait_for, lambda: device()["status"] == "connected", 5, "connected")
                seq, deadline = 0, time.monotonic() + 10
                while time.monotonic() < deadline:  # the HIP pressed into the sandbox's box: a contact vibration
                    await ws.send(msgpack.packb({"type": "tracker", "seq": seq, "t": time.time() * 1e3,
                                                 "pos": [0.0, 0.0, 0.58]}))
                    seq += 1
                    message = msgpack.unpackb(await ws.recv())
                    if message.get("type") == "state" and message["actuator"][0] > 0:
                        return message["actuator"]
                raise AssertionError("no state frame with a drive")

        drive = asyncio.run(page())
        assert drive[:4] == [1.0, 0, 0, 0], drive
        wait_for(lambda: device()["status"] == "disconnected", 5, "disconnected when the page left")
        assert device()["pages"] == [], "the page left: its offer went with it"
    finally:
        stop_server(proc)
