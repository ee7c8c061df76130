"""Where the loop and the other server processes run (server/cpu_plan.py): pure rules."""

from __future__ import annotations

import pytest

from server.cpu_plan import MODES, OWN_FROM_CPUS, plan_cpus


def test_shared_pins_the_loop_to_the_highest_cpu_and_leaves_every_cpu_to_the_others():
    plan = plan_cpus({0, 1, 2, 3}, "shared")
    assert (plan.loop, plan.others, plan.own) == (3, frozenset({0, 1, 2, 3}), False)


def test_own_keeps_the_others_off_the_loops_cpu_even_on_two_cpus():
    assert plan_cpus({0, 1}, "own").to_dict() == {"mode": "own", "loop": 1, "others": [0], "own": True}
    plan = plan_cpus({2, 5, 7}, "own")  # a cpuset's CPUs, not numbered from 0
    assert (plan.loop, sorted(plan.others)) == (7, [2, 5])


def test_auto_is_own_from_four_cpus_and_shared_below():
    assert not plan_cpus(range(OWN_FROM_CPUS - 1), "auto").own
    plan = plan_cpus(range(OWN_FROM_CPUS), "auto")
    assert plan.own and plan.loop == OWN_FROM_CPUS - 1 and len(plan.others) == OWN_FROM_CPUS - 1


@pytest.mark.parametrize("mode", MODES)
def test_one_cpu_pins_nothing_and_shares_it(mode):
    plan = plan_cpus({4}, mode)
    assert (plan.loop, plan.others, plan.own) == (None, frozenset({4}), False)


def test_a_bad_mode_or_no_cpu_is_a_clear_error():
    with pytest.raises(ValueError, match="auto, shared, own"):
        plan_cpus({0, 1}, "exclusive")
    with pytest.raises(ValueError, match="no usable CPU"):
        plan_cpus(set(), "auto")
