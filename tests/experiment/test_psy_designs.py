"""The designs (server/psychophysics/designs.py): a level → the intervals, seeded per trial; the
answers; correctness; what the procedure hears."""

from collections import Counter

import pytest

from server.psychophysics.designs import Design, Presentation, correct, outcome, present

TWO_IFC = Design("2ifc", 2, ("1", "2"))
THREE_AFC = Design("nafc", 3, ("1", "2", "3"), reference=5.0)
YES_NO = Design("yes-no", 1, ("yes", "no"), catch_rate=0.25)
SAME_DIFF = Design("same-different", 2, ("same", "different"), reference=250.0, different_rate=0.5)
IDENT = Design("identification", 1, ("a", "b", "c"), stimuli=(10.0, 20.0, 30.0))


def test_the_same_seed_presents_the_same_trial():
    for design in (TWO_IFC, THREE_AFC, YES_NO, SAME_DIFF):
        assert present(design, 12.0, 99) == present(design, 12.0, 99)


def test_nafc_puts_the_level_in_one_random_interval_and_the_reference_elsewhere():
    targets = Counter()
    for seed in range(3000):
        p = present(THREE_AFC, 12.0, seed)
        targets[p.target] += 1
        assert p.levels[p.target - 1] == 12.0 and [v for k, v in enumerate(p.levels) if k != p.target - 1] == [5.0, 5.0]
        assert correct(THREE_AFC, p, str(p.target)) and not correct(THREE_AFC, p, str(p.target % 3 + 1))
        assert outcome(THREE_AFC, p, str(p.target)) is True
    assert set(targets) == {1, 2, 3} and all(900 <= n <= 1100 for n in targets.values()), targets
    p = present(TWO_IFC, 7.0, 1)
    assert None in p.levels and 7.0 in p.levels, "a blank reference: marked, no cue"
    assert TWO_IFC.guess == 0.5 and THREE_AFC.guess == pytest.approx(1 / 3)


def test_yes_no_catch_trials_at_the_declared_rate_tell_the_procedure_nothing():
    catch = [not present(YES_NO, 12.0, seed).signal for seed in range(4000)]
    assert 0.22 <= sum(catch) / len(catch) <= 0.28
    signal, blank = Presentation((12.0,), signal=True), Presentation((None,), signal=False)
    assert correct(YES_NO, signal, "yes") and correct(YES_NO, blank, "no") and not correct(YES_NO, blank, "yes")
    assert outcome(YES_NO, signal, "yes") is True and outcome(YES_NO, signal, "no") is False
    assert outcome(YES_NO, blank, "yes") is None and YES_NO.guess == 0.0


def test_same_different_pairs():
    kinds = Counter()
    for seed in range(2000):
        p = present(SAME_DIFF, 300.0, seed)
        if p.signal:
            kinds[p.levels] += 1
            assert correct(SAME_DIFF, p, "different") and not correct(SAME_DIFF, p, "same")
        else:
            assert p.levels == (250.0, 250.0) and correct(SAME_DIFF, p, "same")
            kinds["same"] += 1
    assert all(400 <= kinds[k] <= 600 for k in ((300.0, 250.0), (250.0, 300.0))), kinds
    assert 900 <= kinds["same"] <= 1100 and SAME_DIFF.guess == 0.5


def test_identification_presents_its_level_and_scores_the_label():
    p = present(IDENT, 20.0, 0)
    assert p.levels == (20.0,) and p.stimulus_index == 1
    assert correct(IDENT, p, "b") and not correct(IDENT, p, "a") and outcome(IDENT, p, "c") is False
    assert IDENT.guess == pytest.approx(1 / 3)
    with pytest.raises(ValueError, match="not one of the identification's stimuli"):
        present(IDENT, 25.0, 0)
