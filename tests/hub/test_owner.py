"""One thread owns the hub (server/hub/owner.py): a call from another thread is refused by the
owner check, and `Owner.call` runs a function on the owner's thread from any thread."""

from __future__ import annotations

import asyncio
import threading

import pytest

from server.hub.hub import Hub
from server.hub.owner import HubForWorkers, Owner, WrongThread
from server.hub.supervisor import LoopSupervisor
from server.loop.process import LoopConfig
from server.ipc.records import Log, RecordEvery


def test_unbound_owner_lets_anyone_in():
    owner = Owner()
    owner.check()
    assert owner.call(threading.get_ident) == threading.get_ident()


def test_calls_from_other_threads_are_refused_and_marshalled_ones_run_on_the_loop():
    async def go():
        owner = Owner("the test hub")
        owner.bind()
        owner.check()  # the loop's own thread
        me = threading.get_ident()

        def worker():
            with pytest.raises(WrongThread, match="the test hub"):
                owner.check()
            assert owner.call(threading.get_ident) == me
            with pytest.raises(KeyError):  # the callee's exception reaches the caller
                owner.call({}.__getitem__, "missing")
            return "done"

        assert await asyncio.to_thread(worker) == "done"
        assert owner.call(threading.get_ident) == me  # on the owner thread: a plain call

    asyncio.run(go())


def test_the_hub_and_the_supervisor_refuse_other_threads():
    async def go():
        hub = Hub(server_name="test", tick_hz=1000, state_hz=60, send_to_loop=lambda record: supervisor.send(record))
        supervisor = LoopSupervisor(LoopConfig(), hub.link.on_loop_record)
        supervisor.owner = hub.owner
        hub.owner.bind()
        hub.link.set_recording(0)  # fine here (no loop process: the record is dropped)

        def worker():
            for call in (lambda: hub.link.set_recording(5), lambda: supervisor.send(RecordEvery(5)),
                         lambda: hub.link.on_loop_record(Log("warning", "x"))):
                with pytest.raises(WrongThread):
                    call()
            HubForWorkers(hub, hub.owner).set_recording(5)  # the engine's way in

        await asyncio.to_thread(worker)
        assert hub.link.record_every == 5

    asyncio.run(go())
