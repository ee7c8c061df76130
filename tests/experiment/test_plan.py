"""Session plans: the thesis study for 13 participants, counterbalancing, reproducibility, phases."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest

from server.experiment.order import balanced_latin_square, seeded_permutation
from server.experiment.plan import plan_session, task_order
from server.experiment.study import load_study, parse_study

ROOT = Path(__file__).resolve().parents[2]
THESIS = ROOT / "studies" / "thesis-2021.toml"
PARTICIPANTS = range(13)
HEAD = 'id = "mini"\ntitle = "Mini"\nseed = 5\nparticipants = 6\n'


@pytest.fixture(scope="module")
def thesis():
    return load_study(THESIS)


def mini(body: str):
    return parse_study(HEAD + body, "mini.toml")


def main_conditions(plan, task_id):
    return [p.condition for p in plan if p.task == task_id and p.kind == "main"]


# ---- the thesis study --------------------------------------------------------------------------

def test_every_main_condition_runs_exactly_repetitions_times(thesis):
    for i in PARTICIPANTS:
        plan = plan_session(thesis, i)
        for task in thesis.tasks:
            counts = Counter(main_conditions(plan, task.id))
            assert counts == {c: task.repetitions for c in range(len(task.conditions))}, (i, task.id)


def test_plan_structure(thesis):
    for i in PARTICIPANTS:
        plan = plan_session(thesis, i)
        assert [p.seq for p in plan] == list(range(len(plan)))
        assert len(plan) == len(plan_session(thesis, 0))
        by_task: dict[str, list] = {}
        for p in plan:
            by_task.setdefault(p.task, []).append(p)
        assert list(by_task) == [t.id for t in task_order(thesis, i)]  # a task's items are contiguous
        for task_id, items in by_task.items():
            task = thesis.task(task_id)
            kinds = [p.kind for p in items]
            assert kinds == sorted(kinds, key=["training", "trial", "main", "questionnaire"].index)
            for kind in set(kinds):
                assert [p.index for p in items if p.kind == kind] == list(range(kinds.count(kind)))
            for p in items:
                assert (p.scenario, p.device, dict(p.scenario_params)) == (task.scenario, task.device,
                                                                           dict(task.params))
                if p.kind in ("trial", "main"):
                    assert dict(p.params) == dict(task.conditions[p.condition])
                    assert p.questions == tuple(q.id for q in task.questions)
                    assert p.duration_s == task.time_limit_s
                elif p.kind == "questionnaire":
                    assert p.questions == tuple(q.id for q in task.end_questions) and p.params == {}
                else:
                    assert p.condition is None and p.questions == ()
        json.dumps([p.to_dict() for p in plan])


def test_thesis_phases(thesis):
    plan = plan_session(thesis, 4)
    angle = [p for p in plan if p.task == "contact_angle"]
    assert [p.kind for p in angle] == ["training"] + ["trial"] * 3 + ["main"] * 10
    assert angle[0].duration_s == 120.0 and angle[1].duration_s == 30.0 and angle[0].params == {}
    assert len({p.condition for p in angle if p.kind == "trial"}) == 3  # drawn without replacement
    references = [p for p in plan if p.task == "texture_pairs" and p.kind == "training"]
    assert [p.params["period_us"] for p in references] == [6000.0, 2000.0]  # roughest, then smoothest
    assert sum(p.duration_s for p in references) == 60.0
    patterns = [p for p in plan if p.task == "positioning_patterns"]
    assert [p.kind for p in patterns] == ["trial"] * 2 + ["main"] * 9 + ["questionnaire"]
    assert patterns[-1].questions == ("best_pattern",)
    production = [p for p in plan if p.task == "stiffness_production"]
    assert all(p.questions == () for p in production) and len(production) == 10


def test_vibration_mode_order_is_counterbalanced_7_6(thesis):
    file_order = [t.id for t in thesis.tasks]
    block_positions = [file_order.index("mode_continuous"), file_order.index("mode_none")]
    firsts = Counter()
    for i in PARTICIPANTS:
        order = [t.id for t in task_order(thesis, i)]
        others = [tid for tid in order if tid not in ("mode_continuous", "mode_none")]
        assert others == [tid for tid in file_order if tid not in ("mode_continuous", "mode_none")]
        first = order[block_positions[0]]
        assert {first, order[block_positions[1]]} == {"mode_continuous", "mode_none"}
        assert first == ("mode_continuous" if i % 2 == 0 else "mode_none")
        firsts[first] += 1
        assert order.index("modes_questionnaire") > max(block_positions)  # asked after both modes
    assert firsts == {"mode_continuous": 7, "mode_none": 6}  # thesis §5.5.2: 7 and 6 participants


def test_latin_task_is_balanced_across_participants(thesis):
    n = len(thesis.task("texture_pairs").conditions)
    orders = [main_conditions(plan_session(thesis, i), "texture_pairs") for i in PARTICIPANTS]
    assert orders[:2 * n] == balanced_latin_square(n)  # participant i gets row i
    full_cycle = orders[:2 * n]  # 10 participants: every position and every carry-over twice
    for position in range(n):
        assert Counter(o[position] for o in full_cycle) == {c: 2 for c in range(n)}
    adjacent = Counter((o[k], o[k + 1]) for o in full_cycle for k in range(n - 1))
    assert set(adjacent.values()) == {2} and len(adjacent) == n * (n - 1)
    for position in range(n):  # all 13: as even as 13 allows
        counts = Counter(o[position] for o in orders)
        assert len(counts) == n and max(counts.values()) - min(counts.values()) <= 1


def test_random_orders_follow_the_documented_seed_parts(thesis):
    for i in (0, 7, 12):
        n = len(thesis.task("contact_angle").conditions)
        expected = seeded_permutation(range(n), (thesis.seed, i, "contact_angle", 0))
        assert main_conditions(plan_session(thesis, i), "contact_angle") == expected
    orders = {tuple(main_conditions(plan_session(thesis, i), "contact_angle")) for i in PARTICIPANTS}
    assert len(orders) == 13  # different participants get different orders


def test_same_participant_same_plan_in_fresh_processes(thesis):
    code = ("import json, sys; from server.experiment.study import load_study; "
            "from server.experiment.plan import plan_session; "
            "study = load_study(sys.argv[1]); "
            "print(json.dumps([[p.to_dict() for p in plan_session(study, i)] for i in (0, 5)]))")
    outs = []
    for hash_seed in ("0", "12345"):
        env = {**os.environ, "PYTHONHASHSEED": hash_seed}
        done = subprocess.run([sys.executable, "-c", code, str(THESIS)], cwd=ROOT, env=env, capture_output=True,
                              text=True, check=True)
        outs.append(json.loads(done.stdout))
    here = [[p.to_dict() for p in plan_session(thesis, i)] for i in (0, 5)]
    assert outs[0] == outs[1] == json.loads(json.dumps(here))
    assert plan_session(thesis, 3) == plan_session(thesis, 3)


# ---- orders, repetitions, practice, blocks -------------------------------------------------

CONDITIONS3 = "conditions = [{ angle_deg = -30 }, { angle_deg = 0 }, { angle_deg = 30 }]\n"


def test_repetitions_present_each_condition_once_per_repetition():
    for order in ("fixed", "random", "latin"):
        study = mini(f'[[tasks]]\nid = "a"\nscenario = "contact-angle"\n{CONDITIONS3}'
                     f'repetitions = 3\norder = "{order}"\n')
        for i in range(6):
            main = [p for p in plan_session(study, i) if p.kind == "main"]
            assert [p.repetition for p in main] == [0] * 3 + [1] * 3 + [2] * 3
            rounds = [[p.condition for p in main if p.repetition == r] for r in range(3)]
            assert all(sorted(r) == [0, 1, 2] for r in rounds)
            if order == "fixed":
                assert rounds == [[0, 1, 2]] * 3
            if order == "latin":  # the participant's row, in every repetition
                assert rounds == [balanced_latin_square(3)[i]] * 3


def test_practice_draws_cycle_through_the_conditions():
    study = mini(f'[[tasks]]\nid = "a"\nscenario = "contact-angle"\n{CONDITIONS3}practice = 7\n')
    practice = [p for p in plan_session(study, 2) if p.kind == "trial"]
    assert [p.repetition for p in practice] == [0, 0, 0, 1, 1, 1, 2]
    for cycle in (0, 1):
        assert sorted(p.condition for p in practice if p.repetition == cycle) == [0, 1, 2]
    assert [p.index for p in practice] == list(range(7))


def test_training_only_and_questionnaire_only_tasks():
    study = mini('[[tasks]]\nid = "explore"\nscenario = "positioning"\ntraining_s = 90\n'
                 '[[tasks]]\nid = "ask"\nscenario = "positioning"\n'
                 '[[tasks.end_questions]]\nid = "c"\nkind = "text"\ntext = "Comments?"\nrequired = false\n')
    plan = plan_session(study, 0)
    assert [(p.task, p.kind, p.duration_s, p.questions) for p in plan] == [
        ("explore", "training", 90.0, ()), ("ask", "questionnaire", None, ("c",))]


def test_block_of_three_keeps_its_positions_and_balances_order():
    tasks = "".join(f'[[tasks]]\nid = "{t}"\nscenario = "contact-angle"\n{CONDITIONS3}' for t in "abcde")
    study = mini(tasks + '[[blocks]]\nid = "trio"\ntasks = ["b", "d", "e"]\n')
    rows = balanced_latin_square(3)
    seen = Counter()
    for i in range(12):
        order = [t.id for t in task_order(study, i)]
        assert order[0] == "a" and order[2] == "c"  # outside the block: untouched
        trio = [order[1], order[3], order[4]]
        assert trio == [["b", "d", "e"][k] for k in rows[i % 6]]
        seen.update(enumerate(trio))
    assert set(seen.values()) == {4}  # 12 participants: each task 4 times at each block position


def test_fixed_block_uses_the_listed_order():
    tasks = "".join(f'[[tasks]]\nid = "{t}"\nscenario = "contact-angle"\n{CONDITIONS3}' for t in "ab")
    study = mini(tasks + '[[blocks]]\nid = "ba"\ntasks = ["b", "a"]\norder = "fixed"\n')
    assert [t.id for t in task_order(study, 1)] == ["b", "a"]


def test_bad_participant_index(thesis):
    for bad in (-1, 1.5, True):
        with pytest.raises(ValueError):
            plan_session(thesis, bad)
