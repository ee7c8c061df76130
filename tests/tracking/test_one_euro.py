import math
import random

import pytest

from server.tracking.one_euro import OneEuro, OneEuro3, OneEuroParams, alpha


def paper_filter(xs, ts, mincutoff, beta, dcutoff):
    """Casiez et al. 2012, written out from the paper's equations (1)-(5) with plain arithmetic."""
    out, x_hat, dx_hat = [], None, 0.0
    for i, (x, t) in enumerate(zip(xs, ts)):
        if i == 0:
            x_hat = x
            out.append(x)
            continue
        te = t - ts[i - 1]
        a_d = 1.0 / (1.0 + (1.0 / (2 * math.pi * dcutoff)) / te)
        dx = (x - x_hat) / te
        dx_hat = a_d * dx + (1 - a_d) * dx_hat
        fc = mincutoff + beta * abs(dx_hat)
        a = 1.0 / (1.0 + (1.0 / (2 * math.pi * fc)) / te)
        x_hat = a * x + (1 - a) * x_hat
        out.append(x_hat)
    return out


@pytest.mark.parametrize("mincutoff,beta,dcutoff", [(1.0, 0.0, 1.0), (0.5, 5.0, 1.0), (2.0, 0.7, 3.0)])
def test_matches_the_papers_formula_at_1e12(mincutoff, beta, dcutoff):
    rng = random.Random(7)
    ts, t = [], 0.0
    for _ in range(500):
        t += rng.uniform(0.006, 0.012)  # irregular sampling, as a tracker's
        ts.append(t)
    xs = [math.sin(3 * t) + rng.gauss(0, 0.01) for t in ts]
    f = OneEuro(OneEuroParams(mincutoff, beta, dcutoff))
    ours = [f(x, t) for x, t in zip(xs, ts)]
    expected = paper_filter(xs, ts, mincutoff, beta, dcutoff)
    assert max(abs(a - b) for a, b in zip(ours, expected)) < 1e-12


def test_alpha_by_hand():
    # fc = 1 Hz, Te = 0.01 s: tau = 1/(2π), alpha = 1/(1 + 100/(2π))
    assert alpha(1.0, 0.01) == pytest.approx(1 / (1 + 100 / (2 * math.pi)), abs=1e-15)


def test_first_sample_passes_and_repeated_time_holds():
    f = OneEuro()
    assert f(3.0, 1.0) == 3.0
    y = f(4.0, 1.01)
    assert 3.0 < y < 4.0
    assert f(100.0, 1.01) == y  # no time passed: no new estimate


def test_beta_cuts_lag_on_a_ramp():
    ts = [i / 100 for i in range(200)]
    slow = OneEuro(OneEuroParams(1.0, 0.0))
    fast = OneEuro(OneEuroParams(1.0, 10.0))
    lag_slow = [t - slow(t, t) for t in ts][-1]
    lag_fast = [t - fast(t, t) for t in ts][-1]
    assert lag_fast < lag_slow / 3


def test_vector_filters_each_axis_alone():
    f3 = OneEuro3(OneEuroParams(1.0, 2.0))
    f = OneEuro(OneEuroParams(1.0, 2.0))
    for i in range(50):
        t = i / 110
        out = f3((math.sin(t), 0.0, 5.0), t)
        assert out[0] == f(math.sin(t), t)
        assert out[1] == 0.0 and out[2] == pytest.approx(5.0, abs=1e-12)


def test_bad_params_refused():
    with pytest.raises(ValueError):
        OneEuroParams(0.0, 0.0)
    with pytest.raises(ValueError):
        OneEuroParams(1.0, -1.0)
