"""Issue 35 point 4 against a real server: a client that stops reading its socket (with a small
receive buffer, as a stalled headset's) holds at most a few frames; on resume it reads those and
then the current frame, not a backlog (a 30 s stall once gave 3 MB of frames, the first 33.8 s
old). The client is a plain TCP socket driven by websockets' sans-I/O client protocol, so that
"not reading" means no recv() at all: no library reads on its behalf."""

from __future__ import annotations

import socket
import time

import msgpack
import pytest
from websockets.client import ClientProtocol
from websockets.frames import Opcode
from websockets.http11 import Response
from websockets.typing import Subprotocol
from websockets.uri import parse_uri

from tests.live_server import admin_token

pytestmark = pytest.mark.slow

RECEIVE_BUFFER = 4096  # asked of SO_RCVBUF before connecting (the kernel doubles it)
STALL_S = 4.0
STALE_FRAMES_AT_MOST = 48  # in flight when the reader stopped (33 measured); a backlog is 60 a second of stall
STALE_BYTES_AT_MOST = 32 * 1024


class RawClient:
    def __init__(self, url: str):
        uri = parse_uri(url)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RECEIVE_BUFFER)
        self.sock.connect((uri.host, uri.port))
        self.protocol = ClientProtocol(uri, subprotocols=[Subprotocol("viestac.v1.msgpack")], max_size=1 << 22)
        self.protocol.send_request(self.protocol.connect())
        self._flush()
        self.pending: list[dict] = []
        self.bytes_read = 0
        deadline = time.monotonic() + 5.0
        while not any(isinstance(e, Response) for e in self._read(deadline)):
            pass
        self.send({"type": "hello", "v": 1, "role": "observer", "client": "slow-reader", "token": admin_token(url)})

    def _flush(self) -> None:
        for data in self.protocol.data_to_send():
            if data:
                self.sock.sendall(data)

    def _read(self, deadline: float) -> list:
        self.sock.settimeout(max(0.01, deadline - time.monotonic()))
        data = self.sock.recv(65536)
        assert data, "the server closed the connection"
        self.bytes_read += len(data)
        self.protocol.receive_data(data)
        events = self.protocol.events_received()
        self._flush()  # pongs
        for event in events:
            if getattr(event, "opcode", None) == Opcode.BINARY:
                self.pending.append(msgpack.unpackb(event.data))
        return events

    def send(self, message: dict) -> None:
        self.protocol.send_binary(msgpack.packb(message))
        self._flush()

    def next_state(self, timeout: float = 5.0) -> dict:
        deadline = time.monotonic() + timeout
        while True:
            while self.pending:
                message = self.pending.pop(0)
                if message["type"] == "state":
                    return message
            self._read(deadline)


def test_a_reader_that_stalls_gets_the_current_frame_after_a_few_not_a_backlog(own_server):
    client = RawClient(own_server.ws_url)
    client.next_state()
    t_end = time.monotonic() + 0.5
    while time.monotonic() < t_end:  # reading along: the connection's steady state
        client.next_state()
    client.pending.clear()
    time.sleep(STALL_S)  # no recv(): the receive buffer fills, then the server's send path
    resumed = time.monotonic()
    bytes_before, stale, first_age = client.bytes_read, 0, None
    while True:
        state = client.next_state()
        age = time.monotonic() - state["t"]  # the frame's tick on this machine's CLOCK_MONOTONIC
        first_age = age if first_age is None else first_age
        if state["t"] >= resumed - 0.05:  # ticked about when we came back: current
            break
        stale += 1
    stale_bytes = client.bytes_read - bytes_before
    took = time.monotonic() - resumed
    client.sock.close()
    assert stale <= STALE_FRAMES_AT_MOST and stale_bytes <= STALE_BYTES_AT_MOST, (
        f"after a {STALL_S:g} s stall: {stale} stale frames, {stale_bytes} bytes before a current one "
        f"(the first {first_age:.2f} s old)")
    assert took < 1.0, f"the current frame came {took:.2f} s after resuming"
