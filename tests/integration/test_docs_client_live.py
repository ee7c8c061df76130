"""A client written from docs/protocol.md alone, against the real server: it reproduces the scene
hash from the `scene` message it received (recipe "Scene hash", step 3 in JavaScript as the doc
gives it, run by node) and predicts the force of every state from the scene's materials, the
state's `stiffness` overrides and the god-object's spring (`force` = k·(proxy − hip)) — also
after a key changed the stiffness at run time. Nothing here imports the server's code (only the bench's helper that starts and stops it)."""

from __future__ import annotations

import asyncio
import json
import shutil
import subprocess
import time

import pytest
import websockets

from tests.live_server import admin_token, get_json, start_server, stop_server

# The doc's step 3 in JavaScript: JSON.stringify with every object's keys sorted; then SHA-256.
NODE_SCENE_HASH = r"""
const sorted = v => Array.isArray(v) ? v.map(sorted)
  : (v !== null && typeof v === 'object') ? Object.fromEntries(Object.keys(v).sort().map(k => [k, sorted(v[k])]))
  : v;
let text = '';
process.stdin.on('data', d => { text += d; });
process.stdin.on('end', () => {
  const canonical = JSON.stringify(sorted(JSON.parse(text)));
  process.stdout.write(require('crypto').createHash('sha256').update(canonical, 'utf8').digest('hex').slice(0, 16));
});
"""


def scene_hash_by_the_doc(scene: dict) -> str:
    out = subprocess.run(["node", "-e", NODE_SCENE_HASH], input=json.dumps(scene), capture_output=True,
                         text=True, check=True, timeout=30)
    return out.stdout


def predicted_force(state: dict, scene: dict) -> list[float] | None:
    """k·(proxy − hip) for a state touching one body; k from `stiffness`, else the scene's material."""
    if len(state["contacts"]) != 1:
        return None
    body = state["contacts"][0][0]
    scene_k = {o["id"]: o["material"]["stiffness_n_per_m"] for o in scene["objects"]}
    k = state["stiffness"].get(body, scene_k[body])
    return [k * (p - h) for p, h in zip(state["proxy"], state["hip"])]


async def _recv(ws, timeout: float = 5.0) -> dict:
    return json.loads(await asyncio.wait_for(ws.recv(), timeout))


@pytest.fixture
def own_server():
    """A server of its own: the test switches the scenario, which a shared server must not see."""
    proc, base = start_server("contact-angle")
    try:
        yield base
    finally:
        stop_server(proc)


@pytest.mark.skipif(shutil.which("node") is None, reason="needs node for the doc's JavaScript recipe")
def test_a_client_from_the_doc_reproduces_the_scene_hash_and_predicts_the_force(own_server):
    async def go():
        ws_url = own_server.replace("http://", "ws://") + "/ws"
        async with websockets.connect(ws_url, subprotocols=["viestac.v1.json"]) as ws:
            await ws.send(json.dumps({"type": "hello", "v": 1, "role": "participant", "client": "doc-client",
                                      "token": admin_token(ws_url)}))
            assert (await _recv(ws))["type"] == "welcome"
            await asyncio.to_thread(get_json, own_server + "/api/scenario", "POST", body={"name": "stiffness"})
            while (message := await _recv(ws))["type"] != "scene" or message["scene"]["name"] != "stiffness":
                pass
            scene_message = message
            assert scene_hash_by_the_doc(scene_message["scene"]) == scene_message["hash"]

            right = next(o for o in scene_message["scene"]["objects"] if o["id"] == "right")
            centre, radius = right["pose"]["pos"], right["shape"]["radius"]
            top = [centre[0], centre[1], centre[2] + radius + scene_message["scene"]["hip"]["proxy_radius"] - 0.004]
            states, seq, keys_sent = [], 0, 0
            deadline = time.monotonic() + 20
            while time.monotonic() < deadline:
                await ws.send(json.dumps({"type": "tracker", "seq": seq, "t": time.time() * 1e3, "pos": top}))
                seq += 1
                message = await _recv(ws)
                if message["type"] != "state":
                    continue
                assert message["scene"] == scene_message["hash"]
                states.append(message)
                touching = [s for s in states if predicted_force(s, scene_message["scene"]) is not None]
                if keys_sent < 2 and len(touching) >= 5:  # two levels softer: 100 → 80 N/m
                    await ws.send(json.dumps({"type": "input", "key": "ArrowDown", "action": "down"}))
                    keys_sent += 1
                if any(s["stiffness"].get("right") == 80 for s in touching[-5:]) and len(touching) > 20:
                    break
            return scene_message["scene"], states

    scene, states = asyncio.run(go())
    touching = [s for s in states if predicted_force(s, scene) is not None]
    softened = [s for s in touching if s["stiffness"].get("right") == 80]
    assert softened, f"no state after the key with the new stiffness: {[s['stiffness'] for s in states[-5:]]}"
    assert any(not s["stiffness"] for s in touching), "the scene's own stiffness before the key"
    for s in touching:
        assert s["force"] == pytest.approx(predicted_force(s, scene), abs=2e-6), s["tick"]
    # the prediction needs the override: with the scene's 100 N/m it would be 25 % off
    scene_k = next(o for o in scene["objects"] if o["id"] == "right")["material"]["stiffness_n_per_m"]
    assert scene_k == 100 and abs(softened[-1]["force"][2]) < 0.9 * scene_k * 0.004
