"""Issue 36's acceptance on bounded, seeded samples: the same experiments `viestac bench
psychophysics` runs at full size (server/bench/psychophysics.py; numbers in docs/psychophysics.md)."""

import pytest

from server.bench import psychophysics as bench


@pytest.mark.parametrize("name", ["1-up/2-down", "1-up/3-down", "weighted 0.75", "weighted 0.9"])
def test_staircases_converge_to_their_targets(name):
    result = bench.staircase_convergence(name, runs=400)
    assert abs(result["error_points"]) <= 1.5, result


def test_quest_plus_after_40_trials_is_no_worse_than_one_up_three_down_after_80():
    grid = bench.quest_grid_spec(thresholds=41, slopes=8, lapses=3, levels=41)
    result = bench.quest_against_staircase(observers=150, grid=grid)
    assert result["quest_plus_40_rms_db"] <= result["up_down_1_3_80_rms_db"], result


def test_the_bootstrap_interval_covers_the_true_threshold_about_95_percent():
    result = bench.bootstrap_coverage(data_sets=120, samples=300)
    # 120 data sets: a binomial SE of 2 points around 95 %
    assert 0.89 <= result["coverage"] <= 0.99, result


def test_the_miller_madow_correction_reduces_the_small_sample_bias():
    result = bench.information_bias(matrices=1000)
    assert result["ml_bias_bits"] > 0.1  # the plug-in estimate from 40 trials is biased upwards
    assert abs(result["corrected_bias_bits"]) < 0.6 * result["ml_bias_bits"], result
