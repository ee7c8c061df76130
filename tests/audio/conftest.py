"""A real audio server for the audio tests: JACK with its dummy driver (Debian jackd2), a server
of its own per test (unique name, `-n`), started and stopped here; skipped where jackd, JACK-Client
or sounddevice (PortAudio) are missing."""

import shutil

import pytest

from devices.audio.jack_server import JackServer


def _silence_jack():
    import jack

    jack.set_error_function(lambda message: None)  # "cannot connect to server" while we wait for it
    jack.set_info_function(lambda message: None)


@pytest.fixture
def jack_server():
    if shutil.which("jackd") is None:
        pytest.skip("jackd is not installed (Debian: jackd2)")
    pytest.importorskip("jack", reason="JACK-Client is not installed (the audio extra)")
    pytest.importorskip("sounddevice", reason="sounddevice is not installed (the audio extra)")
    _silence_jack()
    server = JackServer(rate=48_000, period=64, outputs=2).start()
    try:
        yield server
    finally:
        server.stop()
