"""The `leap[:URL]` tracker source: the Leap Motion service's WebSocket (server/tracking/leap_client.py),
millimetres and the Leap's axes until calibrated (calibration.leap_default)."""

from __future__ import annotations

from server.tracking import leap_client, leap_frames
from server.tracking.calibration import leap_default
from server.tracking.source_kind import Feed, SourceKind, SourceSpec

LEAP_URL = "ws://127.0.0.1:6437/v6.json"


def parse(rest: str, text: str) -> SourceSpec:
    url = rest or LEAP_URL
    if not url.startswith(("ws://", "wss://")):
        raise ValueError(f"--tracker {text!r}: a Leap URL starts with ws:// (e.g. {LEAP_URL})")
    return SourceSpec("leap", "leap", url, nominal_hz=leap_frames.NOMINAL_HZ)


async def run(source: Feed) -> None:
    def on_frame(frame, recv_ns):
        if frame.points:
            conf = sum(frame.confidence.values()) / len(frame.confidence) if frame.confidence else 1.0
            t_s = frame.timestamp_us / 1e6 if frame.timestamp_us else recv_ns / 1e9
            source.sample(frame.points, t_s, conf)

    def on_state(note, connected):
        source.health.note, source.health.connected = note, connected
        if not connected:
            source.pipeline.reset_filters()  # a reconnect starts a new track

    await leap_client.run(source.spec.target, on_frame, on_state)


KIND = SourceKind("leap", "leap[:URL]", parse, run, calibration=leap_default)
