"""The declared workspace: where a tracked point may be, in scene coordinates.

Every ViESTac scene fits in a few scene units around the origin (docs/protocol.md "Scene
format"); a tracker that reports a point 10 units away is broken or hostile. The wire refuses a
tracker `pos` outside the workspace (`out_of_range`, server/wire/check.py) and the core clamps
what reaches it anyway (server/core/tool.py), so no finite input can carry the god-object to
magnitudes where its arithmetic overflows (|x| ~ 1e154 squares to infinity).
"""

from __future__ import annotations


from server.core.haptics.vec import Vec3

WORKSPACE_HALF_EXTENT_M = 10.0  # |x|, |y|, |z| <= this, scene units


def in_workspace(p) -> bool:
    """True when every coordinate of `p` is finite and within +-WORKSPACE_HALF_EXTENT_M."""
    h = WORKSPACE_HALF_EXTENT_M
    return -h <= p[0] <= h and -h <= p[1] <= h and -h <= p[2] <= h  # NaN compares False


def clamp_to_workspace(p) -> Vec3:
    """`p` with each coordinate clamped to the workspace; a NaN coordinate becomes 0 (the centre),
    an infinite one the nearest face."""
    h = WORKSPACE_HALF_EXTENT_M
    return (_clamp(p[0], h), _clamp(p[1], h), _clamp(p[2], h))


def _clamp(v: float, h: float) -> float:
    v = float(v)
    if v != v:  # NaN
        return 0.0
    return -h if v < -h else h if v > h else v
