"""The shapes of what the loop records, shared by the loop (which writes them) and the experiment
store and export (which keep them). Declared here, at the bottom of the layers, so that importing
the store does not load the loop, every scenario and trimesh."""

# One row per recorded tick: held = the id of the object the participant carries (or None), and
# held_x/y/z its position.
TRAJECTORY_COLUMNS = ("tick", "hip_x", "hip_y", "hip_z", "proxy_x", "proxy_y", "proxy_z", "contact",
                      "held", "held_x", "held_y", "held_z")

# The export's trajectory file (docs/data.md) names its time `t_s` and the HIP's tracked position
# hip_x/y/z: the columns that stand for `t,x,y,z` when it is read back as a trajectory (render, replay).
EXPORT_TRAJECTORY_AS_SAMPLES = {"t": "t_s", "x": "hip_x", "y": "hip_y", "z": "hip_z"}

# Several tracked points (more than one tool, or a hand's other joints): one row per recorded
# tick, [tick, {point name: [x, y, z]}] of every tool's tracked point (not a position a scenario
# holds it at) and every point that drives no tool; the primary tool is in the trajectory row too.
# Export writes them as the multi-point CSV `viestac render` reads (server/render.py).
POINT_ROW = ("tick", "points")


# The loop's timing, one row of three int64 per tick in a state record's `samples` bytes: the
# period since the previous tick began, the tick's cost (from its start to its last send), and 1
# when the tick published a state record, else 0. The hub's telemetry reads them
# (server/hub/telemetry.py): a tick that publishes does several times the work of one that does
# not, so their costs are told apart.
TIMING_SAMPLE = ("period_ns", "cost_ns", "published")


def multipoint_columns(names) -> tuple[str, ...]:
    """The multi-point CSV header for `names`: `t` (seconds), then NAME.x, NAME.y, NAME.z each."""
    return ("t",) + tuple(f"{name}.{axis}" for name in names for axis in "xyz")
