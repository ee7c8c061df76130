"""TCP_NODELAY on the server's end of every accepted connection (docs/performance.md, "Tracker →
state round trip"): without it a state frame waited for the client's ACK, up to 48 ms.

The first test reads the option off the socket of a running `viestac serve` from outside
(pidfd_getfd, server/bench/roundtrip_sockets.py); the others check the listening socket that
`viestac serve` hands uvicorn, under asyncio and under a plain accept()."""

from __future__ import annotations

import asyncio
import errno
import socket

import msgpack
import pytest
import websockets

from tests.live_server import admin_token, start_server, stop_server
from server.bench.roundtrip_sockets import peer_socket_nodelay
from server.cli import listen_socket


def _nodelay(sock: socket.socket) -> bool:
    return bool(sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY))


def test_the_server_end_of_an_accepted_ws_connection_of_viestac_serve_has_tcp_nodelay():
    proc, base = start_server("contact-angle")
    try:
        async def check() -> tuple[bool, bool]:
            async with websockets.connect(base.replace("http://", "ws://") + "/ws", compression=None) as ws:
                await ws.send(msgpack.packb({"type": "hello", "v": 1, "role": "observer", "token": admin_token(base)}))
                await ws.recv()  # welcome: accepted
                own = ws.transport.get_extra_info("socket")
                try:
                    server_end = peer_socket_nodelay(proc.pid, own.getsockname())
                except OSError as exc:
                    if exc.errno in (errno.EPERM, errno.ENOSYS):  # no ptrace access / kernel < 5.6
                        pytest.skip(f"cannot read another process's socket here: {exc}")
                    raise
                return server_end, _nodelay(own)

        server_end, client_end = asyncio.run(check())
    finally:
        stop_server(proc)
    assert server_end, "the server's end of the /ws connection lets Nagle hold state frames"
    assert client_end, "the websockets client (bench, load generator) sets TCP_NODELAY itself"


@pytest.mark.parametrize("host", ["127.0.0.1", "::1"])
def test_connections_accepted_by_asyncio_on_the_serve_socket_have_tcp_nodelay(host):
    sock = listen_socket(host, 0)
    accepted: list[bool] = []

    class Record(asyncio.Protocol):
        def connection_made(self, transport):
            accepted.append(_nodelay(transport.get_extra_info("socket")))
            transport.close()

    async def serve_one() -> None:
        server = await asyncio.get_running_loop().create_server(Record, sock=sock)  # as uvicorn does
        async with server:
            with socket.create_connection(sock.getsockname()[:2]):
                while not accepted:
                    await asyncio.sleep(0.01)

    asyncio.run(asyncio.wait_for(serve_one(), 5))
    assert accepted == [True]


def test_a_plain_accept_on_the_serve_socket_inherits_tcp_nodelay():
    """What any event loop gets from the kernel, whether or not it sets the option itself."""
    with listen_socket("127.0.0.1", 0) as sock:
        sock.listen()
        with socket.create_connection(sock.getsockname()):
            conn, _ = sock.accept()
            with conn:
                assert _nodelay(conn)
