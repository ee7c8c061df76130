"""Trackers: sources of tracked points (Leap Motion, replays, scripts), their calibration into the
scene frame, a 1€ filter per point, health, and the tracker host process that sends the result
to the loop's tracker UDP port (docs/trackers.md).

Sans-I/O cores: one_euro, calibration, health, leap_frames, replay, scripted, pipeline.
Shells: leap_client (WebSocket), tracker_host_process (the tracker host), leap_emulator.
"""
