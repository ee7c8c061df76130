"""The scene's placement for WebXR (server/api/placement_routes.py): a rig default, one per
participant session, bounds checked, kept on disk."""

from __future__ import annotations

import asyncio

import httpx

from server.app import create_app
from server.config import Settings

ROOM = {"table_height_m": 0.74, "origin_m": [0.1, -0.4], "yaw_deg": 15.0, "scale_m_per_unit": 0.08}


def _call(app, calls):
    async def run():
        transport = httpx.ASGITransport(app=app, raise_app_exceptions=True)
        async with httpx.AsyncClient(transport=transport, base_url="http://127.0.0.1") as client:
            return [await client.request(m, u, headers={"Authorization": f"Bearer {t}"}, json=b) for m, u, t, b in calls]
    return asyncio.run(run())


def test_rig_and_session_placements(tmp_path):
    app = create_app(Settings(data_dir=tmp_path, tracker_udp="off"))
    access = app.state.access
    admin, who = access.book.create("admin", None, label="admin")
    assert access.lease.request(who)["status"] == "granted"
    part_a, _ = access.book.create("participant", "lab-a", session="s-a", label="a")
    part_b, _ = access.book.create("participant", "lab-a", session="s-b", label="b")

    (empty,) = _call(app, [("GET", "/api/placement", part_a, None)])
    assert empty.json() == {"rig": None, "session": None, "session_id": "s-a", "placement": None}

    rig, mine, bad, refused = _call(app, [
        ("PUT", "/api/placement/rig", admin, ROOM),
        ("PUT", "/api/placement/session", part_a, {**ROOM, "table_height_m": 0.9}),
        ("PUT", "/api/placement/session", part_a, {**ROOM, "scale_m_per_unit": 0}),
        ("PUT", "/api/placement/session", admin, ROOM),  # the admin opened no participant session
    ])
    assert rig.status_code == 200 and mine.status_code == 200
    assert bad.status_code == 422 and refused.status_code == 409
    # staff without the lease may not place the session the holder opened (another lab's)
    access.lease.session = "s-a"
    other, _ = access.book.create("experimenter", "lab-b", label="b")
    holder_places, other_places = _call(app, [("PUT", "/api/placement/session", admin, ROOM),
                                              ("PUT", "/api/placement/session", other, {**ROOM, "yaw_deg": 90.0})])
    assert holder_places.status_code == 200 and holder_places.json()["session_id"] == "s-a"
    assert other_places.status_code == 409
    access.lease.session = None
    _call(app, [("PUT", "/api/placement/session", part_a, {**ROOM, "table_height_m": 0.9})])
    a, b = _call(app, [("GET", "/api/placement", part_a, None), ("GET", "/api/placement", part_b, None)])
    assert a.json()["placement"]["table_height_m"] == 0.9 and a.json()["rig"] == ROOM
    assert b.json()["session"] is None and b.json()["placement"] == ROOM, "another session falls back to the rig's"

    # kept on disk: a new server on the same data directory has them
    again = create_app(Settings(data_dir=tmp_path, tracker_udp="off"))
    token, _ = again.state.access.book.create("participant", "lab-a", session="s-a", label="a2")
    (a2,) = _call(again, [("GET", "/api/placement", token, None)])
    assert a2.json()["session"]["table_height_m"] == 0.9
