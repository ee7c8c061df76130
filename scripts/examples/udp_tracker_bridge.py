#!/usr/bin/env python3
"""Example tracker bridge: send tracked points to ViESTac's tracker UDP port (docs/trackers.md).

Adapt `read_points()` to your device (a Novint Falcon through libnifalcon's bindings, a
motion-capture SDK, ...): return {point name: (x, y, z)} in the SCENE frame and scene units
(calibrate first), or {} when the device sees nothing. This script does the rest: one msgpack
`tracker` datagram per sample (protocol v1.4: `pos` + `point` for the primary finger, `points`
for the others, `ttl` so the server releases the fingers within 100 ms if this bridge stops).

    python scripts/examples/udp_tracker_bridge.py --port 8001 --rate 120

Needs only the standard library and msgpack (pip install msgpack). The port is the server's
`tracker_udp` (GET /api/health; 8001 for a server on 8000); it listens on loopback only, so run
the bridge on the rig PC.
"""

import argparse
import math
import socket
import time

import msgpack

PRIMARY = "right.index.tip"


def read_points(t: float) -> dict:
    """REPLACE THIS with your device's read-out. The demo circles above the contact-angle dome."""
    a = 2 * math.pi * t / 4.0
    index = (0.0, 0.25 * math.cos(a), 0.8 + 0.05 * math.sin(a))
    return {PRIMARY: index, "right.thumb.tip": (0.0, index[1] - 0.15, index[2] - 0.05)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=8001)
    parser.add_argument("--rate", type=float, default=120.0, help="samples per second")
    args = parser.parse_args()
    ttl_ms = min(max(4000.0 / args.rate, 20.0), 60.0)  # 4 periods, within 20..60 ms
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setblocking(False)
    period, start, seq = 1.0 / args.rate, time.monotonic(), 0
    while True:
        seq += 1
        time.sleep(max(0.0, start + seq * period - time.monotonic()))  # absolute deadlines: no drift
        points = read_points(time.monotonic() - start)
        if not points:
            continue  # nothing tracked: send nothing; the server releases the fingers after ttl
        name = PRIMARY if PRIMARY in points else sorted(points)[0]
        message = {"type": "tracker", "seq": seq, "t": time.monotonic() * 1000.0, "pos": list(points[name]),
                   "point": name, "ttl": ttl_ms,
                   "points": {n: list(p) for n, p in points.items() if n != name}}
        try:
            sock.sendto(msgpack.packb(message), (args.host, args.port))
        except BlockingIOError:
            pass  # a full buffer: the next sample supersedes this one
        try:  # the server answers a refused datagram with one `error` datagram: show it
            print("server:", msgpack.unpackb(sock.recv(4096)))
        except (BlockingIOError, ConnectionRefusedError):
            pass


if __name__ == "__main__":
    main()
