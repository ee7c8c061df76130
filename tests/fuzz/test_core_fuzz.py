"""Property test (hypothesis) of the loop's core: any finite tracker positions, ±1e308 included,
never make a tick raise out of Loop, and the next sane sample renders a sane proxy (on the
dome's surface or at the HIP). Bounded and derandomized."""

from __future__ import annotations

import math

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from scenarios.contact_angle import ContactAngle
from server.core.workspace import WORKSPACE_HALF_EXTENT_M
from server.loop.tick import Loop
from server.loop.simulation import Simulation
from server.ipc.records import TrackerSample

MS = 1_000_000
DOME_R = 0.66  # dome radius 0.6 plus the proxy radius 0.06
coord = st.one_of(st.floats(allow_nan=False, allow_infinity=False),
                  st.sampled_from([1e154, 1.35e154, -1e154, 1e308, -1e308, 10.0, -10.0, 0.0, 5e-324]))
positions = st.lists(st.tuples(coord, coord, coord), min_size=1, max_size=6)
SANE = [(0.1, 0.1, 0.5), (0.0, 0.0, 1.2), (0.3, -0.2, 0.7)]
CORE = Loop(Simulation(ContactAngle()))  # one core: the state a hostile sequence leaves behind carries over


@settings(max_examples=300, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(positions, st.sampled_from(SANE), st.integers(min_value=1, max_value=3))
def test_any_finite_positions_never_wedge_the_core(hostile, sane, ticks_each):
    core = CORE
    seq = core.sim.data.tick
    for pos in hostile:
        for _ in range(ticks_each):
            t = core.sim.data.tick
            out = core.tick([TrackerSample(1, seq, 0.0, list(pos), None, t * MS)], t * MS)
            seq += 1
            if out.result is not None:
                assert all(math.isfinite(v) and abs(v) <= WORKSPACE_HALF_EXTENT_M + 1 for v in out.result.proxy)
    t = core.sim.data.tick
    core.tick([TrackerSample(1, seq, 0.0, list(sane), None, t * MS)], t * MS)
    for _ in range(3):
        t = core.sim.data.tick
        out = core.tick((), t * MS)
    assert out.error is None and out.result is not None
    proxy = out.result.proxy
    r = math.sqrt(sum(v * v for v in proxy))
    inside = math.sqrt(sum(v * v for v in sane)) < DOME_R
    if inside:
        assert abs(r - DOME_R) < 1e-6, (sane, proxy)
    else:
        assert proxy == sane
