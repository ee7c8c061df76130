"""The device host's side of an audio worker's socket (devices/audio/device.py): every report a
worker sent arrives, also when it exits with stimuli of ours unread, and a worker that never
reports is killed and tried again instead of leaving the device `connecting` for ever."""

import socket
import sys
import time

import pytest

from devices.audio.config import AudioChannel, AudioConfig
from devices.audio.device import AudioDevice, worker_records
from server import ipc
from server.ipc.records import FROM_AUDIO_WORKER, AudioStatus, AudioStimuli


def pair():
    return socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)


def test_a_refusal_sent_by_a_worker_that_left_our_stimuli_unread_still_arrives():
    host, worker = pair()
    host.send(ipc.pack(AudioStimuli(1, [])))          # the host's stimuli, never read by the worker ...
    worker.send(ipc.pack(AudioStatus("refused", "unsupported sample rate 44100 Hz for 'system'")))
    worker.close()                                     # ... which exits after its refusal
    # What the kernel does (Linux, AF_UNIX SEQPACKET): the reset is reported before the refusal,
    # so a reader that takes the reset for the end loses the refusal.
    twin_host, twin_worker = pair()
    twin_host.send(b"x")
    twin_worker.send(b"refusal")
    twin_worker.close()
    with pytest.raises(ConnectionResetError):
        twin_host.recv(1 << 20)
    assert twin_host.recv(1 << 20) == b"refusal"

    records = [ipc.unpack(data, FROM_AUDIO_WORKER) for data in worker_records(host, 5.0)]
    assert records == [AudioStatus("refused", "unsupported sample rate 44100 Hz for 'system'")]


def test_records_end_when_the_worker_closes_and_a_silent_start_is_signalled_once():
    host, worker = pair()
    worker.send(ipc.pack(AudioStatus("connected", "streaming")))
    worker.close()
    assert len(list(worker_records(host, 5.0))) == 1
    host, worker = pair()
    records = worker_records(host, 0.2)
    assert next(records) is None  # nothing within 0.2 s
    worker.close()
    assert list(records) == []


class SilentWorker(AudioDevice):
    """A worker that never says a word (as one waiting in PortAudio on an audio server that does
    not answer would)."""

    def worker_command(self, fd: int) -> list[str]:
        return [sys.executable, "-c", "import time; time.sleep(600)"]


def test_a_worker_that_never_reports_is_killed_named_and_tried_again():
    config = AudioConfig(output="system", host_api="JACK", channels=(AudioChannel("coil", 1),))
    device = SilentWorker("coil", config, 250.0, reopen_interval_s=0.1, start_timeout_s=0.5)
    device.start()
    try:
        deadline = time.monotonic() + 30.0
        while device.workers < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert device.workers >= 2, "the silent worker was not replaced"
        assert "the audio worker did not report within 0.5 s" in device.last_error
        assert "audio:system@JACK" in device.last_error
        assert device.status == "connecting"
    finally:
        device.stop(drain_s=0.0)
