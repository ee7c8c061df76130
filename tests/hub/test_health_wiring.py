"""Health wired into the hub, without a web server: the capability check reads connection state, a
trial that needs a disconnected device is refused unless forced, the hub turns the loop's records
and the device host's reports into health, and each session is sent a `health` message after its
welcome and whenever the status or the reason codes change."""

import asyncio
import struct

import pytest

from devices.capability import check
from devices.profiles import profile_by_model
from scenarios.contact_angle import ContactAngle
from scenarios import registry
from server.app import create_app
from server.config import Settings
from server.hub.control import DeviceMissing, ScenarioControl, ScenarioRefused
from server.hub.hub import Hub
from server.hub.session import ServerInfo, Session
from server.wire import codec
from server.wire.check import check_message
from tests.hub.access_fakes import gate, with_token
from server.ipc.records import Fault, Recovered, ScenarioAnnounce
from tests.ipc import loop_state

RIG = {"fingertac": profile_by_model("fingertac"), "ferrovibe": profile_by_model("ferrovibe")}
FERRO_GONE = {"fingertac": "connected", "ferrovibe": "disconnected"}


# ---- the capability check and trials read connection state -------------------------------------

def test_a_disconnected_device_is_not_usable_in_the_capability_listing():
    report = check("contact-angle", ("macro_roughness",), RIG, FERRO_GONE)
    assert not report.ok and report.usable == ()
    ferro = next(d for d in report.to_dict()["devices"] if d["name"] == "ferrovibe")
    assert ferro["status"] == "disconnected" and ferro["usable"] is False
    assert "ferrovibe shows macro-roughness (tilt) but is disconnected" in report.message
    assert report.to_dict()["missing"] == [{"dimension": "macro_roughness", "devices": ["ferrovibe"],
                                            "statuses": ["disconnected"]}]
    connected = check("contact-angle", ("macro_roughness",), RIG, {"ferrovibe": "connected"})
    assert connected.ok and connected.usable == ("ferrovibe",) and connected.missing == ()
    # texture is still served by the FingerTac
    texture = check("texture", ("fine_roughness",), RIG, FERRO_GONE)
    assert texture.ok and texture.usable == ("fingertac",) and texture.missing == ()


def control(statuses):
    sent = []
    ctl = ScenarioControl(lambda record: sent.append(record) or True, lambda: RIG, lambda: statuses)
    ctl.scenario_cls = ContactAngle
    return ctl, sent


def test_a_trial_that_needs_a_disconnected_device_is_refused_unless_forced():
    statuses = dict(FERRO_GONE)
    ctl, sent = control(statuses)
    with pytest.raises(DeviceMissing) as refused:
        ctl.set_trial("main", {"angle_deg": 10})
    assert isinstance(refused.value, ScenarioRefused), "REST maps it to 409 like a refused switch"
    assert "device 'ferrovibe' is disconnected" in refused.value.report.message
    assert "force" in refused.value.report.message and sent == []
    assert ctl.set_trial("main", {"angle_deg": 10}, force=True)["phase"] == "main"
    assert ctl.set_trial(None) is None, "ending a trial needs no device"
    statuses["ferrovibe"] = "connected"
    ctl.set_trial("main", {"angle_deg": 10})
    assert len(sent) == 3
    statuses["ferrovibe"] = "handshaking"
    with pytest.raises(DeviceMissing):
        ctl.require_devices("contact-angle")
    ctl.require_devices("texture")  # the FingerTac shows fine roughness
    ctl.scenario_cls = registry.resolve("texture").factory
    ctl.require_devices()


def test_a_device_with_no_status_yet_counts_as_connected():
    ctl, sent = control({})
    ctl.set_trial("main", {"angle_deg": 10})
    assert sent


# ---- the session's health hook --------------------------------------------------------------------

def health_frames(status, codes=()):
    message = {"type": "health", "status": status, "reasons": [{"code": c, "message": c} for c in codes]}
    check_message(message)
    return {fmt: codec.encode(message, fmt) for fmt in codec.FORMATS}


def taken(session):
    out = []
    while (item := session.outbox.next_frame()) is not None:
        out.append(codec.decode(item, session.fmt))
    return out


@pytest.mark.parametrize("fmt", codec.FORMATS)
def test_a_session_gets_health_after_its_welcome_and_scene_and_only_the_latest(fmt):
    session = Session(3, fmt, ServerInfo("t", 1000, 60.0), 0, gate=gate()[0])
    session.set_health(health_frames("ok"))
    session.set_scene("aaaa", {f: codec.encode({"type": "scene", "v": 1, "hash": "aaaa", "scene": {}}, f)
                               for f in codec.FORMATS})
    session.receive(codec.encode(with_token({"type": "hello", "v": 1, "role": "observer"}), fmt), 1)
    assert [m["type"] for m in taken(session)] == ["welcome", "scene", "health"], "a v1.0 reader: welcome, scene"
    session.set_health(health_frames("degraded", ["loop_down"]))
    session.set_health(health_frames("degraded", ["loop_down", "device_missing"]))
    got = taken(session)
    assert [m["type"] for m in got] == ["health"], "a health still queued is superseded"
    assert [r["code"] for r in got[0]["reasons"]] == ["loop_down", "device_missing"]


# ---- the hub feeds health and tells clients -------------------------------------------------------

def samples(*periods_us):
    return b"".join(struct.pack("<qqq", int(p * 1000), 30_000, 0) for p in periods_us)


def state_record(failures=0, periods=(1000,)):
    return {"frame": 1, "tick": 1, "t": 0.0, "scene": "s", "hip": [0, 0, 0], "proxy": [0, 0, 0],
            "force": [0, 0, 0], "contact": False, "contacts": [], "objects": [], "cues": [], "hud": "",
            "values": {}, "samples": samples(*periods), "trackers": [], "failures": failures}


def test_the_hub_turns_records_and_reports_into_health_and_tells_each_client():
    async def go():
        hub = Hub(server_name="test", tick_hz=1000, state_hz=60, overrun_threshold=2, send_to_loop=lambda record: True)
        hub.health_feed.health.startup_grace_s = 0.0  # the loop "started" a moment ago: count its overruns at once
        hub.health_feed.device_profiles = RIG
        hub.link.on_loop_record(ScenarioAnnounce({"id": "contact-angle-v1", "params": {}, "seed": 0, "trial": None}))
        session = Session(1, "json", ServerInfo("t", 1000, 60.0), 0, gate=gate()[0])
        hub.health_feed.on_child_start("loop")
        hub.health_feed.on_child_start("device_host")
        assert hub.health_feed.check_health().status == "starting"
        session.set_health(hub.fanout.health_frames)
        session.receive(codec.encode(with_token({"type": "hello", "v": 1, "role": "observer"}), "json"), 1)
        assert taken(session)[-1]["status"] == "starting"

        class Conn:
            wake = asyncio.Event()
        Conn.session = session
        hub.fanout.connections[1] = Conn
        hub.link.on_device_report({"refusals": [], "status": {"fingertac": "connected", "ferrovibe": "connected"}})
        hub.link.on_loop_record(loop_state(state_record()))
        assert hub.health_feed.check_health().status == "ok" and taken(session)[-1]["status"] == "ok"

        hub.link.on_device_report({"refusals": [], "status": {"fingertac": "connected", "ferrovibe": "disconnected"}})
        got = taken(session)
        assert got[-1]["status"] == "degraded" and got[-1]["reasons"][0]["code"] == "device_missing"
        assert "'ferrovibe' is disconnected" in got[-1]["reasons"][0]["message"]
        with pytest.raises(DeviceMissing):
            hub.control.set_trial("main", {"angle_deg": 0})
        hub.health_feed.check_health()
        assert taken(session) == [], "nothing new: no message"

        hub.link.on_loop_record(Fault.from_array(["fault", {"failures": 1, "tick": 9, "error": "OverflowError: x"}]))
        assert [r["code"] for r in taken(session)[-1]["reasons"]] == ["tick_failures", "device_missing"]
        hub.link.on_loop_record(Recovered.from_array(["recovered", {"tick": 10, "failures": 1}]))
        hub.link.on_loop_record(loop_state(state_record(failures=1, periods=(1000, 2000, 2000, 2500))))
        hub.health_feed.check_health()  # state records are judged by the periodic check (HealthFeed.watch_health)
        assert [r["code"] for r in taken(session)[-1]["reasons"]] == ["device_missing", "overruns"]

        hub.health_feed.on_child_exit("device_host", -9)
        assert {"device_host_down"} <= {r["code"] for r in hub.health_feed.check_health().reasons}
        with pytest.raises(DeviceMissing):
            hub.control.set_trial("main", {"angle_deg": 0})
        hub.health_feed.on_child_exit("loop", -9)
        assert "loop_down" in hub.health_feed.check_health().codes

    asyncio.run(go())


def test_the_overrun_threshold_setting_reaches_health(tmp_path):
    with pytest.raises(ValueError, match="overrun_threshold"):
        Settings(overrun_threshold=-1)
    app = create_app(Settings(overrun_threshold=25, data_dir=tmp_path, simulated_rig=False, tracker_udp="off"))
    assert app.state.hub.health_feed.health.overrun_threshold == 25


class FakeChild:
    def __init__(self):
        self.proc = None

    @property
    def alive(self):
        return self.proc is not None and self.proc.returncode is None


class FakeProc:
    def __init__(self):
        self.returncode = None


def test_the_periodic_check_sees_exits_and_restarts_even_between_two_polls():
    async def go():
        hub = Hub(server_name="test", tick_hz=1000, state_hz=60)
        events = []
        hub.health_feed.on_child_start = lambda what: events.append(("start", what))
        hub.health_feed.on_child_exit = lambda what, code: events.append(("exit", what, code))
        loop, host = FakeChild(), FakeChild()
        task = asyncio.create_task(hub.health_feed.watch_health({"loop": loop, "device_host": host}))
        loop.proc, host.proc = FakeProc(), FakeProc()
        await asyncio.sleep(0.06)
        assert sorted(events) == [("start", "device_host"), ("start", "loop")]
        events.clear()
        loop.proc.returncode = -9
        await asyncio.sleep(0.06)
        assert events == [("exit", "loop", -9)]
        events.clear()
        host.proc.returncode = 1
        host.proc = FakeProc()  # exited and restarted before the next poll
        await asyncio.sleep(0.06)
        assert events == [("exit", "device_host", 1), ("start", "device_host")]
        task.cancel()

    asyncio.run(go())
