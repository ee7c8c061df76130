"""Simulated device sinks for a rig without hardware.

SimulatedFerroVibe stands in for the FerroVibe (spec.md "Device facts") until the device layer
with profiles, the framed serial protocol and the pty emulators lands: it turns tilt cues into
tilt commands and records them with their simulation time, exactly when they would be sent
(on change only, like the real link must). Pure: the loop hands it time and cues.
"""

from __future__ import annotations

from collections import deque

from devices.cues import Cue, Tilt


class SimulatedFerroVibe:
    name = "ferrovibe-sim"

    def __init__(self, history: int = 10_000):
        self.commands: deque[dict] = deque(maxlen=history)  # newest last
        self._last: tuple[float, float] | None = None  # (direction, magnitude); None = flat

    def submit(self, t_s: float, cues: tuple[Cue, ...]) -> list[dict]:
        """Apply this tick's cues; return the commands it sent (empty when nothing changed)."""
        tilt = next((c for c in cues if isinstance(c, Tilt)), None)
        wanted = None if tilt is None or tilt.magnitude_pct == 0.0 else (tilt.direction_deg, tilt.magnitude_pct)
        if wanted == self._last:
            return []
        self._last = wanted
        if wanted is None:
            command = {"device": self.name, "t": t_s, "command": "flat"}
        else:
            command = {"device": self.name, "t": t_s, "command": "tilt",
                       "direction_deg": wanted[0], "magnitude_pct": wanted[1]}
        self.commands.append(command)
        return [command]
