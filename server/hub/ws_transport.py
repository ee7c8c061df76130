"""The /ws transport: uvicorn's websockets (sans-I/O) protocol with a bounded write path, so a
client that stops reading holds at most a few frames (docs/protocol.md "Slow readers").

The hub's sender (server/hub/fanout.py) awaits each send, and uvicorn's send waits while the
transport is paused, i.e. while its write buffer is above the high-water mark. Unbounded, that
wait never came: the kernel's send buffer grows by autotuning to megabytes, so a client that
stopped reading for 30 s was "sent" 3,302 frames with none dropped and on resume read 3 MB of
them, the first 33.8 s old, before a current one (issue 35 point 4). Here every WebSocket
connection gets a small kernel send buffer (SO_SNDBUF, which also ends its autotuning) and a
write high-water mark of about two state frames: the sender blocks after a few frames, and while
it does the client's outbox keeps only the newest state frame (latest-wins, its events carried).
On resume the client reads what was already in flight (the server's few KiB and its own receive
buffer, which only the client sizes), then the current frame. Plain HTTP
connections (the pages' scripts) keep the kernel's defaults: only an upgraded connection comes
here (uvicorn's `ws` protocol class).
"""

from __future__ import annotations

import socket

from uvicorn.protocols.websockets.websockets_sansio_impl import WebSocketsSansIOProtocol

SEND_BUFFER_BYTES = 4 * 1024  # asked of SO_SNDBUF (Linux doubles it, and its least is ~4.6 KB): a few frames
WRITE_HIGH_WATER_BYTES = 1024  # the transport pauses the sender beyond this: about two state frames (~460 B)


class BoundedWebSocketProtocol(WebSocketsSansIOProtocol):
    def connection_made(self, transport) -> None:
        super().connection_made(transport)
        sock = transport.get_extra_info("socket")
        if sock is not None:
            try:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SEND_BUFFER_BYTES)
            except OSError:  # a socket that takes no options (not TCP): the high-water mark still bounds
                pass
        transport.set_write_buffer_limits(high=WRITE_HIGH_WATER_BYTES)
