"""The loop's default publish cadence, defined once (viestac serve --state-hz, Settings,
LoopConfig, Loop, the simulated study's virtual hub)."""

STATE_HZ = 60.0  # state records a second on the cadence; a tick whose cues changed publishes besides
