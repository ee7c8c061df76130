"""The shapes of what the loop records, shared by the loop (which writes them) and the experiment
store and export (which keep them). Declared here, at the bottom of the layers, so that importing
the store does not load the loop, every scenario and trimesh."""

# One row per recorded tick: held = the id of the object the participant carries (or None), and
# held_x/y/z its position.
TRAJECTORY_COLUMNS = ("tick", "hip_x", "hip_y", "hip_z", "proxy_x", "proxy_y", "proxy_z", "contact",
                      "held", "held_x", "held_y", "held_z")
