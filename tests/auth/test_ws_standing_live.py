"""Who may act on a shared rig, against a real server with real WebSocket clients (issues 35 and 34):
a revoked or expired token ends its open /ws connections at once (close 1008 with the reason
"revoked" or "expired") and nothing it sends afterwards is applied; while a recorded trial runs,
another lab's commands, trackers and join links are refused (409 / forbidden, naming the trial's
lab); the holder's own /ws activity and its participant's keep the lease; a trial started after
Release → Request control has its participant session open; a participant is told in words when
its session closes; a second tab of one participant session takes it from the first; the
failed-attempt throttle works per token, not per address; recorded input events name the token and
lab that sent them."""

from __future__ import annotations

import asyncio
import json
import sqlite3
import time

import pytest
import websockets

from server.cli import main as cli
from tests.api.test_access_live import ADMIN, STUDY, call, new_token, ok
from tests.integration.test_server_ws import Client, run
from tests.live_server import start_server, stop_server


@pytest.fixture(scope="module")
def data_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("standing")


@pytest.fixture(scope="module")
def base(data_dir):
    proc, url = start_server(extra=["--data-dir", str(data_dir)])
    try:
        yield url
    finally:
        stop_server(proc)


def ws_url(base: str) -> str:
    return base.replace("http://", "ws://") + "/ws"


def token_id(base: str, secret: str) -> str:
    return ok(call(base, "GET", "/api/auth/me", token=secret))["token_id"]


def join(base: str, holder, session_id: str | None) -> tuple[str, dict]:
    """A join link made by `holder` (the lease holder; ADMIN: the harness's admin), exchanged as the
    participant page does."""
    link = ok(call(base, "POST", "/api/join-links", {"session_id": session_id}, token=holder), 201)
    joined = ok(call(base, "POST", "/api/auth/join", {"code": link["url"].split("#join=", 1)[1]}, token=None))
    return joined["token"], joined["identity"]


async def welcomed(url: str, token: str, role: str = "participant") -> tuple[Client, dict]:
    client = await Client.connect(url, role=role, token=token)
    return client, await client.recv_type("welcome")


async def closed(client: Client, within_s: float) -> tuple[list[dict], int | None, str | None, float]:
    """Reads until the server closes: the errors it sent, the close code and reason, and when."""
    errors = []
    deadline = time.monotonic() + within_s
    with pytest.raises(websockets.ConnectionClosed) as info:
        while True:
            message = await client.recv(timeout=max(0.01, deadline - time.monotonic()))
            if message["type"] == "error":
                errors.append(message)
    rcvd = info.value.rcvd
    return errors, rcvd.code if rcvd else None, rcvd.reason if rcvd else None, time.monotonic()


def tracker_rows(base: str, client_id: int) -> list[list]:
    return [row for row in ok(call(base, "GET", "/api/trackers?limit=4096"))["rows"] if row[0] == client_id]


def sample(seq: int, pos=(0.0, 0.1, 1.2)) -> dict:
    return {"type": "tracker", "seq": seq, "t": seq, "pos": list(pos)}


# ---- 35.1: revocation and expiry reach open connections ----------------------------------------------
def test_revoking_a_token_closes_its_connections_at_once_and_applies_nothing_after(base):
    participant, identity = join(base, ADMIN, None)  # the harness's admin holds the lease
    observer = new_token(base, "observer")

    async def go():
        hand, hello = await welcomed(ws_url(base), participant)
        watcher, _ = await welcomed(ws_url(base), observer, role="observer")
        for seq in range(1, 6):
            await hand.send(sample(seq))
            await asyncio.sleep(0.02)
        deadline = time.monotonic() + 3
        while not tracker_rows(base, hello["client_id"]):
            assert time.monotonic() < deadline, "the participant's samples never reached the loop"
            await asyncio.sleep(0.05)
        for who in (participant, observer):
            ok(call(base, "DELETE", f"/api/tokens/{token_id(base, who)}"))
        revoked_at = time.monotonic()
        for seq in range(100, 110):  # after the 200: none of these may be applied
            try:
                await hand.send(sample(seq, (0.25, 0.12, 0.8)))
                await hand.send({"type": "answer", "seq": 0, "question": "q", "value": 6})
            except websockets.ConnectionClosed:
                break
        return (hello, await closed(hand, 2.0), await closed(watcher, 2.0), revoked_at)

    hello, (hand_errors, hand_code, hand_reason, hand_at), (watch_errors, watch_code, watch_reason, _), t0 = run(go())
    for errors, code, reason in ((hand_errors, hand_code, hand_reason), (watch_errors, watch_code, watch_reason)):
        assert code == 1008 and reason == "revoked", (code, reason)
        assert [e["code"] for e in errors][-1] == "unauthorized" and "revoked" in errors[-1]["message"], errors
    assert hand_at - t0 < 1.0
    assert not [row for row in tracker_rows(base, hello["client_id"]) if row[1] >= 100]
    assert ok(call(base, "GET", "/api/state"))["hip"] != [0.25, 0.12, 0.8]


def test_a_cli_revocation_closes_the_connection_within_a_second(base, data_dir):
    observer = new_token(base, "observer")

    async def go():
        watcher, _ = await welcomed(ws_url(base), observer, role="observer")
        await watcher.recv_type("state")
        assert cli(["token", "revoke", token_id(base, observer), "--data-dir", str(data_dir)]) == 0
        revoked_at = time.monotonic()
        errors, code, reason, at = await closed(watcher, 3.0)
        return errors, code, reason, at - revoked_at

    errors, code, reason, after_s = run(go())
    assert (code, reason) == (1008, "revoked") and errors[-1]["code"] == "unauthorized"
    assert after_s < 1.5, f"closed {after_s:.2f} s after the CLI revoked the token"


def test_an_expired_token_closes_its_connection_with_the_reason(base):
    short = ok(call(base, "POST", "/api/tokens", {"role": "observer", "label": "2 s", "ttl_s": 2}), 201)["token"]

    async def go():
        watcher, _ = await welcomed(ws_url(base), short, role="observer")
        opened = time.monotonic()
        errors, code, reason, at = await closed(watcher, 5.0)
        return errors, code, reason, at - opened

    errors, code, reason, after_s = run(go())
    assert (code, reason) == (1008, "expired")
    assert errors[-1]["code"] == "unauthorized" and "ask for a new link" in errors[-1]["message"]
    assert after_s < 3.0


# ---- 35.2 and 34.2: the running trial's rig -----------------------------------------------------------
def _lab_session(base: str, lab: str, participant: str) -> tuple[str, dict]:
    created = ok(call(base, "POST", "/api/sessions", {"study": STUDY, "participant": participant,
                                                      "experimenter": "al"}, token=lab), 201)
    return created["id"], {"X-Control-Token": created["token"]}


def _take_lease(base: str, who=ADMIN) -> None:
    """`who` holds the lease (by default the harness's admin, as the module's tests expect)."""
    lease = ok(call(base, "GET", "/api/lease", token=who))
    if lease["holder"] is not None and lease["you"] != "holder":
        ok(call(base, "POST", "/api/lease/force-release"))
    assert ok(call(base, "POST", "/api/lease", token=who))["status"] in ("granted", "held")


def test_another_lab_cannot_change_a_running_trial_and_its_participant_keeps_driving(base):
    lab_a, lab_b = new_token(base, "experimenter", "lab-a"), new_token(base, "experimenter", "lab-b")
    _take_lease(base, lab_a)
    sid, control = _lab_session(base, lab_a, "P-A1")
    participant, _ = join(base, lab_a, sid)
    ok(call(base, "POST", f"/api/sessions/{sid}/trials/0/start", token=lab_a, headers=control))
    try:
        ok(call(base, "DELETE", "/api/lease", token=lab_a))
        _take_lease(base, lab_b)
        status, answer = call(base, "POST", "/api/command", {"key": "tap_angle", "value": 60}, token=lab_b)
        assert status == 409 and "lab-a" in answer["detail"], answer
        status, answer = call(base, "POST", "/api/join-links", {"session_id": None}, token=lab_b)
        assert status == 409 and "lab-a" in answer["detail"], answer
        assert ok(call(base, "GET", "/api/lease", token=lab_b))["session"] is None

        async def go():
            hand, hand_hello = await welcomed(ws_url(base), participant)
            other, other_hello = await welcomed(ws_url(base), lab_b, role="operator")
            refusals = []
            for seq in range(1, 40):
                await hand.send(sample(seq))
                await other.send(sample(seq, (0.0, -0.3, 1.4)))
                await asyncio.sleep(0.02)
            end = time.monotonic() + 1.0
            while time.monotonic() < end:
                message = await other.recv(timeout=1.0)
                if message["type"] == "error":
                    refusals.append(message)
            await hand.close()
            await other.close()
            return hand_hello["client_id"], other_hello["client_id"], refusals

        hand_id, other_id, refusals = run(go())
        assert tracker_rows(base, hand_id), "lab A's participant could not drive in its own trial"
        assert not tracker_rows(base, other_id), "lab B's tracker reached the loop during lab A's trial"
        assert refusals and all(r["code"] == "forbidden" and "lab-a" in r["message"] for r in refusals), refusals
    finally:
        ok(call(base, "POST", f"/api/sessions/{sid}/trials/0/abort", {"reason": "test"}, token=lab_a,
                headers=control))
        _take_lease(base)


def test_a_streaming_participant_keeps_its_holders_lease(tmp_path):
    proc, url = start_server(extra=["--lease-ttl", "2"], take_lease=False)
    try:
        lab = new_token(url, "experimenter", "lab-a")
        assert ok(call(url, "POST", "/api/lease", token=lab))["status"] == "granted"
        participant, _ = join(url, lab, None)

        async def go():
            hand, _ = await welcomed(ws_url(url), participant)
            end, seq = time.monotonic() + 4.5, 0  # over twice the ttl, the console silent
            while time.monotonic() < end:
                seq += 1
                await hand.send(sample(seq))
                await asyncio.sleep(0.02)
            await hand.close()

        run(go())
        lease = ok(call(url, "GET", "/api/lease", token=lab))
        assert lease["you"] == "holder", lease
    finally:
        stop_server(proc)


def test_release_request_start_leaves_the_participant_able_to_drive_and_tells_it_in_between(base):
    lab = new_token(base, "experimenter", "lab-c")
    _take_lease(base, lab)
    sid, control = _lab_session(base, lab, "P-C1")
    participant, _ = join(base, lab, sid)

    async def go():
        hand, hello = await welcomed(ws_url(base), participant)
        ok(call(base, "DELETE", "/api/lease", token=lab))  # Release
        told = await hand.recv_type("error")
        ok(call(base, "POST", "/api/lease", token=lab))  # Request control
        ok(call(base, "POST", f"/api/sessions/{sid}/trials/0/start", token=lab, headers=control))  # Start
        lease = await hand.recv_type("lease")
        while lease["session"] != sid:
            lease = await hand.recv_type("lease")
        for seq in range(1, 20):
            await hand.send(sample(seq))
            await asyncio.sleep(0.02)
        errors = []
        end = time.monotonic() + 0.5
        while time.monotonic() < end:
            message = await hand.recv(timeout=1.0)
            if message["type"] == "error":
                errors.append(message)
        await hand.close()
        return hello["client_id"], told, errors

    try:
        hand_id, told, errors = run(go())
        assert told["code"] == "session_closed" and "wait" in told["message"], told
        assert not errors, errors
        assert tracker_rows(base, hand_id), "the participant could not drive in the trial just started"
        assert ok(call(base, "GET", "/api/lease", token=lab))["session"] == sid
    finally:
        ok(call(base, "POST", f"/api/sessions/{sid}/trials/0/abort", {"reason": "test"}, token=lab,
                headers=control))
        _take_lease(base)


# ---- 34.7: a second participant tab --------------------------------------------------------------------
def test_a_second_tab_of_a_participant_session_takes_it_and_the_console_sees_both(base):
    participant, identity = join(base, ADMIN, None)

    async def go():
        first, first_hello = await welcomed(ws_url(base), participant)
        second, second_hello = await welcomed(ws_url(base), participant)
        told = await first.recv_type("error")
        await first.send(sample(1))
        refused = await first.recv_type("error")
        clients = {c["client_id"]: c for c in ok(call(base, "GET", "/api/clients"))}
        await first.close()
        await second.close()
        return first_hello["client_id"], second_hello["client_id"], told, refused, clients

    first_id, second_id, told, refused, clients = run(go())
    assert told["code"] == "session_taken" and "another tab" in told["message"]
    assert refused["code"] == "forbidden" and "another tab" in refused["message"]
    assert clients[first_id]["session"] == clients[second_id]["session"] == identity["session"]
    assert clients[first_id]["replaced_by"] == second_id and clients[second_id]["replaced_by"] is None
    assert not tracker_rows(base, first_id)


# ---- 35.5: the failed-attempt throttle -----------------------------------------------------------------
def test_failures_are_throttled_per_token_not_per_address(base):
    for i in range(12):  # someone on the same address guessing: each guess is answered 401, none 429
        assert call(base, "GET", "/api/lease", token=f"guess-{i:02d}-" + "x" * 30)[0] == 401
    participant, _ = join(base, ADMIN, None)  # a join code from the same address is redeemed
    assert ok(call(base, "GET", "/api/auth/me", token=participant))["role"] == "participant"
    secret = new_token(base, "observer")
    for i in range(5):  # a guesser who knows how this token begins
        assert call(base, "GET", "/api/lease", token=secret[:12] + f"{i}" * 31)[0] == 401
    status, answer = call(base, "GET", "/api/lease", token=secret)  # now not even checked: a 429
    assert status == 429 and "too many failed attempts" in answer["detail"], (status, answer)
    other = new_token(base, "observer")
    assert ok(call(base, "GET", "/api/lease", token=other))["you"] == "none"


# ---- 35.2: events name who caused them -----------------------------------------------------------------
def test_recorded_input_events_name_the_token_and_site_that_sent_them(base, data_dir):
    lab = new_token(base, "experimenter", "lab-e")
    _take_lease(base, lab)
    sid, control = _lab_session(base, lab, "P-E1")
    lab_id = token_id(base, lab)
    ok(call(base, "POST", f"/api/sessions/{sid}/trials/0/start", token=lab, headers=control))
    try:
        ok(call(base, "POST", "/api/command", {"key": "tap_angle", "value": 30}, token=lab))

        async def go():
            console, _ = await welcomed(ws_url(base), lab, role="operator")
            await console.send({"type": "input", "key": "tap_angle", "action": "press", "value": 45})
            deadline = time.monotonic() + 3
            while True:  # the frame that carries the /ws command's event
                state = await console.recv_type("state", timeout=max(0.01, deadline - time.monotonic()))
                mine = [e for e in state["events"] if e.get("name") == "input" and e.get("value") == 45]
                if mine:
                    await console.close()
                    return mine[0]

        event = run(go())
        assert event["by"] == {"token_id": lab_id, "site": "lab-e"}, event
        time.sleep(0.6)  # the recorder writes its rows every 0.25 s
    finally:
        ok(call(base, "POST", f"/api/sessions/{sid}/trials/0/abort", {"reason": "test"}, token=lab,
                headers=control))
        _take_lease(base)
    db = sqlite3.connect(f"file:{data_dir / 'viestac.sqlite'}?mode=ro", uri=True)
    rows = [json.loads(body) for (body,) in db.execute("SELECT body_json FROM events WHERE session_id = ? AND "
                                                       "kind = 'input'", (sid,))]
    db.close()
    by_value = {row.get("value"): row.get("by") for row in rows if row.get("key") == "tap_angle"}
    assert by_value.get(30) == {"token_id": lab_id, "site": "lab-e"}, rows  # the REST command
    assert by_value.get(45) == {"token_id": lab_id, "site": "lab-e"}, rows  # the /ws command
