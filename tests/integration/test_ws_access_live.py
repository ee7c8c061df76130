"""The outsider attempts of issue 19 against the real server on /ws: no token, a bad token, a
participant asking to be the operator, a second participant driving the HIP while the real one
is connected, and the lease message everyone allowed to watch receives."""

from __future__ import annotations

import asyncio
import time

import pytest
import websockets

from tests.live_server import get_json
from tests.integration.test_server_ws import Client, run


async def _closed_with(client: Client) -> tuple[dict, int | None]:
    """The one error the server sends before it closes, and the close code."""
    error = await client.recv()
    with pytest.raises(websockets.ConnectionClosed) as info:
        for _ in range(10):
            await client.recv()
    return error, (info.value.rcvd.code if info.value.rcvd is not None else None)


@pytest.mark.parametrize("token", [None, "not-a-token", "x" * 43])
def test_an_outsider_without_a_valid_token_is_refused_before_any_welcome(live_server, token):
    async def go():
        client = await Client.connect(live_server.ws_url, role="operator", token=token)
        return await _closed_with(client)

    error, code = run(go())
    assert error["type"] == "error" and error["code"] == "unauthorized" and code == 1008


def test_an_outsider_cannot_send_trackers_or_commands_without_a_hello(live_server):
    async def go():
        client = await Client.connect(live_server.ws_url, hello=False)
        await client.send({"type": "input", "key": "tap_angle", "action": "press", "value": 30})
        return await _closed_with(client)

    error, code = run(go())
    assert error["code"] == "unauthorized" and code == 1008


def _participant_token(base: str) -> tuple[str, dict]:
    """A join link made by the harness's admin (the lease holder), exchanged as the page does."""
    link = get_json(base + "/api/join-links", "POST", body={"session_id": None})
    code = link["url"].split("#join=", 1)[1]
    joined = get_json(base + "/api/auth/join", "POST", body={"code": code}, token=None)
    return joined["token"], joined["identity"]


def test_a_participant_asking_to_be_the_operator_is_welcomed_as_a_participant(live_server):
    secret, identity = _participant_token(live_server.http_url)

    async def go():
        client = await Client.connect(live_server.ws_url, role="operator", token=secret)
        got: dict = {}
        while not {"welcome", "lease", "error"} <= set(got):  # welcome, scene, health, lease, then the error
            message = await client.recv()
            got.setdefault(message["type"], message)
        welcome, error, lease = got["welcome"], got["error"], got["lease"]
        # an experimenter command from this connection is refused (it is no operator)
        await client.send({"type": "input", "key": "tap_angle", "action": "press", "value": 30})
        refused = await client.recv_type("error")
        await client.close()
        return welcome, error, lease, refused

    welcome, error, lease, refused = run(go())
    assert welcome["role"] == "participant"
    assert welcome["identity"] == {"token_id": identity["token_id"], "role": "participant",
                                   "site": identity["site"], "session": identity["session"]}
    assert error["code"] == "forbidden"
    assert lease["session"] == identity["session"] and lease["holder"]["role"] == "admin"
    assert refused["code"] == "forbidden"


def test_a_second_participant_cannot_drive_the_hip_while_the_real_one_is_connected(live_server):
    base = live_server.http_url
    stale, _ = _participant_token(base)          # a participant of an earlier session
    real, identity = _participant_token(base)    # the session the lease holder opened now
    assert get_json(base + "/api/lease")["session"] == identity["session"]

    async def go():
        hand = await Client.connect(live_server.ws_url, token=real)
        intruder = await Client.connect(live_server.ws_url, token=stale)
        hand_id = (await hand.recv_type("welcome"))["client_id"]
        intruder_id = (await intruder.recv_type("welcome"))["client_id"]
        refusals, drivers = [], []
        deadline = time.monotonic() + 1.5
        seq = 0
        while time.monotonic() < deadline:
            seq += 1
            await hand.send({"type": "tracker", "seq": seq, "t": seq, "pos": [0.0, 0.1, 1.2]})
            await intruder.send({"type": "tracker", "seq": seq, "t": seq, "pos": [0.0, -0.3, 1.4]})
            await asyncio.sleep(0.01)
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            message = await hand.recv(timeout=1.0)
            if message["type"] == "state" and message.get("driver"):
                drivers.append(message["driver"][0])
        end = time.monotonic() + 0.5  # it watches: state frames keep coming, read what came until now
        while time.monotonic() < end:
            message = await intruder.recv(timeout=1.0)
            if message["type"] == "error":
                refusals.append(message)
        await hand.close()
        await intruder.close()
        return hand_id, intruder_id, drivers, refusals

    hand_id, intruder_id, drivers, refusals = run(go())
    # An earlier source (another test's tracker bridge) may hold the HIP until it has been quiet for
    # DRIVER_QUIET_S; from the participant's first applied sample on, only the participant drives.
    assert hand_id in drivers, f"the participant {hand_id} never drove the HIP: {set(drivers)}"
    since = drivers[drivers.index(hand_id):]
    assert set(since) == {hand_id}, f"the HIP was driven by {set(since)}, the participant is {hand_id}"
    assert intruder_id not in drivers
    assert refusals and {r["code"] for r in refusals} == {"forbidden"}
    # ~150 refused samples in 1.5 s: answered at most once a second
    assert len(refusals) <= 3
    rows = get_json(base + "/api/trackers?limit=4096")["rows"]
    assert any(row[0] == hand_id for row in rows) and not any(row[0] == intruder_id for row in rows)
